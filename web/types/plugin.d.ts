// Declarations of src/plugin.js, hand-written (README.md, "three.js"): the three.js
// GLTFLoader plugin. The three.js types come from @types/three.

import { BufferGeometry, Camera, EventDispatcher, Mesh } from 'three';
import { GLTF, GLTFLoader, GLTFLoaderPlugin, GLTFParser } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { DecoderWorker, DecoderWorkerOptions, RequestHeaders, SessionOptions, View, WorkerStats } from './client.js';

/** A three.js camera as a View: the eye, projection x view, the viewport in pixels. */
export function viewOfCamera(camera: Camera, width: number, height: number): View;

export interface MeshstreamProgressiveOptions extends DecoderWorkerOptions {
  /** added to every GET of the file, e.g. `{ Authorization: 'Bearer ' + token }` */
  headers?: RequestHeaders;
  /** refinements to decode, -1 (the default): all */
  lod?: number;
  /** the refinements from a live session over WebSocket (the scene still from the file's prefix) */
  session?: SessionOptions | null;
  /** a share of the file's datagrams to drop, to watch predictions (default 0) */
  loss?: number;
  /** the seed of that loss (default 1) */
  seed?: number;
  /** predicted vertices orange through vertex colours */
  tintPredicted?: boolean;
  /** a DecoderWorker to share (default: one made here, terminated by dispose) */
  worker?: DecoderWorker;
  /** by ranges: the file's streams split among this many Web Workers (default 1) */
  workers?: number;
  /** by ranges: the streams this view needs first (a view, or a function of the base scene that returns one) */
  view?: View | ((gltf: GLTF) => View | null) | null;
  /** over a session: the least time between two views setView sends (default 250 ms) */
  viewIntervalMs?: number;
}

/** The counters of a load: the workers' (WorkerStats, merged) and the page's. */
export interface ProgressiveStats extends Partial<WorkerStats> {
  /** levels shown */
  levels: number;
  /** bytes of the prefix and of the blobs (or of the session) */
  bytes: number;
  /** views setView sent */
  viewsSent: number;
  /** Web Workers that decoded */
  workers?: number;
}

/** performance.now() of the load's start, of the base parsed and of the last level. */
export interface ProgressiveTimings {
  start: number;
  base: number | null;
  complete: number | null;
}

export interface ProgressiveLevelEvent {
  streamId: number;
  /** refinements applied (0: the base) */
  level: number;
  levels: number;
  vertices: number;
  faces: number;
  predictedVertices: number;
  /** FNV-1a of the arrays (the native decoder's PrimitiveHash) */
  hash: string;
}

export interface MeshstreamProgressiveEventMap {
  /** the scene at its base level, from load() */
  base: { gltf: GLTF };
  /** a stream's newer level, copied into its geometry */
  level: ProgressiveLevelEvent;
  /** every stream at its last level */
  complete: { stats: ProgressiveStats; timings: ProgressiveTimings };
  error: { error: Error };
}

/** A progressive primitive's geometry, refined in place, and the meshes that show it. */
export interface ProgressiveGeometry {
  geometry: BufferGeometry;
  meshes: Mesh[];
  /** the finest level's counts, once the first level came */
  capacity: { vertices: number; indices: number } | null;
  vertices?: number;
}

/**
 * The GLTFLoader plugin:
 *
 *   const progressive = new MeshstreamProgressive({ workerUrl });
 *   loader.register((parser) => progressive.plugin(parser));
 *   const gltf = await progressive.load(loader, url);
 */
export class MeshstreamProgressive extends EventDispatcher<MeshstreamProgressiveEventMap> {
  constructor(options?: MeshstreamProgressiveOptions);
  readonly options: MeshstreamProgressiveOptions;
  /** the (first) decoder worker, once the scene is parsed */
  worker: DecoderWorker | null;
  /** per stream id */
  readonly geometries: Map<number, ProgressiveGeometry>;
  readonly stats: ProgressiveStats;
  readonly timings: ProgressiveTimings;
  /** resolves with the stats at 'complete', rejects at 'error' */
  readonly complete: Promise<ProgressiveStats>;
  /** for GLTFLoader.register */
  plugin(parser: GLTFParser): GLTFLoaderPlugin;
  /** reads the file's prefix by HTTP ranges and parses it with `loader` (plugin() registered on it): the scene at its base level */
  load(loader: GLTFLoader, url: string): Promise<GLTF>;
  /** over a live session, call it every frame: sends the camera when it moved; returns whether it sent */
  setView(camera: Camera, width: number, height: number): boolean;
  /** stops every download or session, frees the workers' decoders; with `geometries`, disposes the refined geometries too */
  dispose(options?: { geometries?: boolean }): void;
}
