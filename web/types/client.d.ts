// Declarations of src/client.js, hand-written (README.md, "Other engines"): the
// plain-JS API for any engine, and what the three.js plugin builds on.

/** Request headers added to every GET of the file, e.g. `{ Authorization: 'Bearer ' + token }` (`meshstream serve --auth`). */
export type RequestHeaders = Record<string, string>;

/**
 * What a camera sees (docs/spec/streaming-protocol.md, "Views"): the eye,
 * projection x view (16 numbers, column-major as three.js stores matrices)
 * and the viewport in pixels. `viewOfCamera` (plugin) makes one of a three.js camera.
 */
export interface View {
  camera: [number, number, number];
  viewProjection: number[];
  width: number;
  height: number;
}

/** A live session over WebSocket (`GET /v1/stream` of `meshstream serve --http-listen`) for the refinements. */
export interface SessionOptions {
  /** e.g. `wss://host:7680/v1/stream` */
  url: string;
  asset: string;
  /** the asset's version; 0 (the default): the latest */
  version?: number;
  /** a bearer token (`--auth`), sent as the WebSocket subprotocol `bearer.TOKEN` */
  token?: string;
  /** refinements the session sends (-1, the default: all) */
  lod?: number;
}

/** Where the worker loads its modules from, when they are not beside it in the layout `meshstream-web-assets` writes. */
export interface ModuleUrls {
  /** the meshstream decoder, `wasm/meshstream_decoder.cjs` */
  decoder?: string;
  /** draco3d's `draco_decoder_nodejs.js` */
  draco?: string;
  /** draco3d's `draco_decoder.wasm` */
  dracoWasm?: string;
}

export interface DecoderWorkerOptions {
  /** the worker's script, `src/worker.js` (default: beside client.js, which a bundler breaks: give it) */
  workerUrl?: string | URL;
  moduleUrls?: ModuleUrls;
}

/** A mesh as the worker posts it (the buffers are transferred, not copied). */
export interface MeshArrays {
  vertices: number;
  /** xyz per vertex */
  positions: Float32Array;
  /** xyz per vertex */
  normals: Float32Array | null;
  /** uv per vertex, per TEXCOORD_n */
  texcoords: Float32Array[];
  /** rgba per vertex */
  colors: Float32Array | null;
  /** three per triangle */
  indices: Uint32Array;
  /** per vertex 1 when exact, 0 when predicted (null at the base) */
  reliable: Uint8Array | null;
  predictedVertices: number;
}

/** The .glb (or its prefix) parsed by src/glb.js. */
export interface Glb {
  /** the glTF JSON */
  json: any;
  /** the binary chunk (in a prefix, up to where the prefix ends) */
  bin: Uint8Array | null;
  /** the file offset of the binary chunk's data (-1: none) */
  binOffset: number;
}

/** Draco attribute ids of a primitive's base. */
export interface DracoIds {
  position: number;
  /** -1: none */
  normal: number;
  texcoords: number[];
  /** -1: none */
  color: number;
}

/** A progressive primitive of the file (`MESHSTREAM_progressive`); `streamId` numbers them in file order. */
export interface ProgressivePrimitive {
  where: string;
  /** the glTF mesh's index */
  mesh: number;
  /** the primitive's index in its mesh */
  primitive: number;
  streamId: number;
  /** the stream blob's bytes (null when the prefix does not hold them) */
  blob: Uint8Array | null;
  /** the stream blob's file offsets, end exclusive */
  blobRange: { start: number; end: number };
  /** the base's Draco bytes */
  base: Uint8Array;
  ids: DracoIds;
  reliable: number[];
}

/** The scene at its base level, from `fetchPrefix`. */
export interface Prefix {
  /** the file's first bytes, up to its first stream blob at least */
  bytes: Uint8Array;
  glb: Glb;
  fileLength: number;
  /** the file offset of the first stream blob */
  prefixEnd: number;
}

/** Where a job's stream blobs come from (the worker's 'open' message, src/worker.js). */
export type JobSource =
  | {
      kind: 'ranges';
      url: string;
      headers: RequestHeaders;
      blobs: { streamId: number; start: number; end: number }[];
      head: Uint8Array;
      headStart: number;
      order?: number[];
    }
  | { kind: 'bytes'; blobs: { streamId: number; bytes: Uint8Array }[] }
  | ({ kind: 'session' } & SessionOptions);

/** A job of the worker: the streams' bases and where their blobs come from. */
export interface JobSpecification {
  streams: { streamId: number; base: Uint8Array; ids: DracoIds }[];
  source: JobSource;
  lod: number;
  loss: number;
  seed: number;
}

export interface JobSpecOptions {
  /** the file's URL (for a read by ranges) */
  url?: string | null;
  headers?: RequestHeaders;
  /** refinements to decode, -1 (the default): all */
  lod?: number;
  /** a share of the file's datagrams to drop, to watch predictions (default 0) */
  loss?: number;
  /** the seed of that loss (default 1) */
  seed?: number;
  session?: SessionOptions | null;
  prefix?: Prefix | null;
  /** by ranges: the streams this view needs first, a ranged GET each */
  view?: View | null;
}

/** The worker's counters of a job, with its 'complete' message. */
export interface WorkerStats {
  /** bytes of the stream blobs (or of the session) */
  bytes: number;
  /** datagrams the simulated loss dropped */
  dropped: number;
  /** per stream, the vertices the decoder predicted */
  predictedVertices: Record<number, number>;
  /** milliseconds in draco3d (the bases) */
  baseMs: number;
  /** milliseconds in the meshstream decoder */
  decodeMs: number;
  /** milliseconds from the job's start to its last level taken */
  workerMs: number;
  source: 'ranges' | 'bytes' | 'session';
  /** by ranges with a view: the streams in the order they were read */
  viewOrder?: number[];
  /** over a session: the views sent and the level plans received */
  viewsSent?: number;
  levelPlans?: number;
}

export interface BaseMessage {
  type: 'base';
  job: number;
  streamId: number;
  mesh: MeshArrays;
}

export interface LevelMessage {
  type: 'level';
  job: number;
  streamId: number;
  /** refinements applied (0: the base) */
  level: number;
  /** refinements the stream has (or `lod`, when smaller) */
  levels: number;
  mesh: MeshArrays;
  /** FNV-1a of the arrays (the native decoder's PrimitiveHash) */
  hash: string;
  /** the finest level's counts, for preallocation */
  capacity: { vertices: number; indices: number };
  /** the job's bytes so far */
  bytes: number;
}

export interface CompleteMessage {
  type: 'complete';
  job: number;
  stats: WorkerStats;
}

export interface ErrorMessage {
  type: 'error';
  job: number | null;
  message: string;
}

export type WorkerMessage = BaseMessage | LevelMessage | CompleteMessage | ErrorMessage;

/**
 * The scene at its base level: the file up to its first stream blob, in one
 * or two ranged GETs.
 */
export function fetchPrefix(url: string, options?: { headers?: RequestHeaders; signal?: AbortSignal }): Promise<Prefix>;

/** The decoder's Web Worker (src/worker.js) and its jobs; one serves many loads. */
export class DecoderWorker {
  constructor(options?: DecoderWorkerOptions);
  readonly worker: Worker;
  /** resolves once the worker loaded both decoders */
  readonly ready: Promise<void>;
  /** starts a job; `handler` gets its messages; returns the job's id */
  open(spec: JobSpecification, handler: (message: WorkerMessage) => void): number;
  /** the page took the stream's last level: the worker may post the next */
  ack(job: number, streamId: number): void;
  /** the camera, for a live session (other jobs ignore it) */
  view(job: number, view: View): void;
  close(job: number): void;
  terminate(): void;
}

/** The worker's job for the refined primitives of `glb`. */
export function jobSpec(glb: Glb, options: JobSpecOptions): { prims: ProgressivePrimitive[]; spec: JobSpecification };

export interface MeshstreamClientOptions extends DecoderWorkerOptions {
  /** the progressive .glb, served with HTTP ranges (e.g. `/v1/assets/bunny/versions/1/progressive`) */
  url: string;
  headers?: RequestHeaders;
  /** refinements to decode, -1 (the default): all */
  lod?: number;
  /** the refinements from a live session (the scene still from the file's prefix) */
  session?: SessionOptions | null;
  /** a share of the file's datagrams to drop, to watch predictions (default 0) */
  loss?: number;
  seed?: number;
  /** by ranges: the streams this view needs first */
  view?: View | null;
  /** a DecoderWorker to share (default: the client makes its own and terminates it in dispose) */
  worker?: DecoderWorker;
}

export interface ClientPrimitive {
  streamId: number;
  /** the glTF mesh's index */
  mesh: number;
  /** the primitive's index in its mesh */
  primitive: number;
  level: number;
  levels: number;
  /** the newest arrays (null until the base) */
  arrays: MeshArrays | null;
}

/** The plain-JS API, for any engine. */
export class MeshstreamClient {
  /** reads the file's prefix, starts the worker (or takes `options.worker`) and the job */
  static open(options: MeshstreamClientOptions): Promise<MeshstreamClient>;
  /** per stream id */
  primitives: ClientPrimitive[];
  worker: DecoderWorker | null;
  job: number | null;
  glb: Glb;
  prefix: Prefix;
  /** performance.now() of the open, of every base and of the last level */
  timings: { opened: number; base: number | null; complete: number | null };
  /** every primitive at its base level */
  on(name: 'base', listener: () => void): this;
  on(name: 'level', listener: (message: LevelMessage) => void): this;
  on(name: 'complete', listener: (stats: WorkerStats) => void): this;
  on(name: 'error', listener: (error: Error) => void): this;
  /** stops the download or session and frees the worker's decoders */
  dispose(): void;
}
