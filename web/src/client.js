// The plain-JS API of meshstream in the browser (docs/design/web.md, "The npm
// package"), for any engine (Babylon.js, custom WebGL); plugin.js builds the
// three.js integration on it.
//
//   const client = await MeshstreamClient.open({ url, headers, lod });
//   client.on('base', () => ...);                 every primitive at its base level
//   client.on('level', ({ streamId, level, levels }) => ...);
//   client.on('complete', (stats) => ...);
//   client.on('error', (error) => ...);
//   client.primitives   [{ streamId, mesh, primitive, arrays }] (glTF mesh and primitive index;
//                       arrays as worker.js posts them: positions, normals, texcoords, colors,
//                       indices, reliable, vertices)
//   client.dispose();   stops the fetch or session, frees the worker's decoders
//
// `url` is a progressive .glb served with HTTP ranges (`meshstream serve
// --http-listen`, docs/spec/http-api.md, or any static server or CDN): the first
// ranged GET reads the scene at its base level (everything before the first
// stream blob), the second streams the blobs, decoded as they arrive. With
// `session: { url, asset, version, token }` the refinements come from a live
// session over WebSocket instead (session.js), the scene still from the file.

import { viewOrder } from './view_order.js';
import { firstBlobOffset, glbJsonEnd, parseGlb, progressivePrimitives } from './glb.js';

// The first ranged GET: most files' JSON and bases are smaller; what it
// reads of the blobs is not read again (jobSpec's `head`).
const FIRST_READ = 16 * 1024;

function rangeHeaders(headers, first, last) {
  return Object.assign({}, headers || {}, { Range: `bytes=${first}-${last}` });
}

async function httpError(response, url) {
  let detail = '';
  try {
    detail = (await response.json()).error || '';
  } catch (e) {
    /* not JSON */
  }
  return new Error(`${url}: HTTP ${response.status}${detail ? ' (' + detail + ')' : ''}`);
}

// Bytes [first, last] of `url`, as a Uint8Array, and the file's length
// (from Content-Range; a 200 gives the whole file).
async function fetchRange(url, headers, first, last, signal) {
  const response = await fetch(url, { headers: rangeHeaders(headers, first, last), signal });
  if (response.status === 200) {
    const all = new Uint8Array(await response.arrayBuffer());
    return { bytes: all.subarray(first, Math.min(last + 1, all.byteLength)), length: all.byteLength };
  }
  if (response.status === 416) return { bytes: new Uint8Array(0), length: first };
  if (response.status !== 206) throw await httpError(response, url);
  const range = /bytes (\d+)-(\d+)\/(\d+)/.exec(response.headers.get('Content-Range') || '');
  if (!range || Number(range[1]) !== first) throw new Error(url + ': a 206 without the Content-Range asked for');
  return { bytes: new Uint8Array(await response.arrayBuffer()), length: Number(range[3]) };
}

// The scene at its base level: the file up to its first stream blob, in one
// or two ranged GETs (the first reads 64 KiB, which holds most files' JSON).
// Returns { bytes (the prefix), glb (parsed, truncated), fileLength }.
export async function fetchPrefix(url, { headers, signal } = {}) {
  let { bytes, length } = await fetchRange(url, headers, 0, FIRST_READ - 1, signal);
  let jsonEnd = glbJsonEnd(bytes);
  if (jsonEnd === null) throw new Error(url + ': not a .glb (' + bytes.byteLength + ' bytes)');
  const more = async (end) => {
    if (bytes.byteLength >= end) return;
    const next = await fetchRange(url, headers, bytes.byteLength, end - 1, signal);
    const joined = new Uint8Array(bytes.byteLength + next.bytes.byteLength);
    joined.set(bytes, 0);
    joined.set(next.bytes, bytes.byteLength);
    bytes = joined;
    if (bytes.byteLength < end) throw new Error(url + ': the file ended at byte ' + bytes.byteLength);
  };
  await more(Math.min(jsonEnd + 8, length));
  let glb = parseGlb(bytes, { truncated: true });
  const binOffset = jsonEnd + 8;
  const prefixEnd = firstBlobOffset(glb.json, binOffset, length);
  await more(prefixEnd);  // what the first read holds beyond it is kept
  glb = parseGlb(bytes, { truncated: true });
  return { bytes, glb, fileLength: length, prefixEnd };
}

// The worker (worker.js) and its jobs. One worker serves many loads.
export class DecoderWorker {
  // `workerUrl`: worker.js (default: beside this file); `moduleUrls`:
  // { decoder, draco, dracoWasm } when not in the bundle's layout.
  constructor({ workerUrl, moduleUrls } = {}) {
    this.worker = new Worker(workerUrl || new URL('./worker.js', import.meta.url), { type: 'module' });
    this.jobs = new Map();
    this.nextJob = 1;
    this.ready = new Promise((resolve, reject) => {
      this.worker.onmessage = (event) => {
        const msg = event.data;
        if (msg.type === 'ready') return resolve();
        if (msg.job === null && msg.type === 'error') return reject(new Error(msg.message));
        const handler = this.jobs.get(msg.job);
        if (handler) handler(msg);
        if (msg.type === 'complete' || msg.type === 'error') this.jobs.delete(msg.job);
      };
      this.worker.onerror = (event) => reject(new Error('the decoder worker failed: ' + (event.message || 'unknown')));
    });
    this.worker.postMessage({ type: 'init', urls: moduleUrls || {} });
  }

  // Starts a job; `handler` gets its messages. Returns the job's id.
  open(spec, handler) {
    const job = this.nextJob++;
    this.jobs.set(job, handler);
    const transfer = spec.streams.map((s) => s.base.buffer);
    this.worker.postMessage(Object.assign({ type: 'open', job }, spec), transfer);
    return job;
  }

  // The page took the stream's last level (worker.js sends the next then).
  ack(job, streamId) {
    if (this.jobs.has(job)) this.worker.postMessage({ type: 'ack', job, streamId });
  }

  // The viewer's camera (a live session sends it to the server; other jobs ignore it).
  view(job, view) {
    if (this.jobs.has(job)) this.worker.postMessage({ type: 'view', job, view });
  }

  close(job) {
    if (!this.jobs.has(job)) return;
    this.jobs.delete(job);
    this.worker.postMessage({ type: 'close', job });
  }

  terminate() {
    this.worker.terminate();
    this.jobs.clear();
  }
}

// The worker's job spec for the refined primitives of `glb`: each base's
// bytes copied (they are transferred), and where the blobs come from.
// `prefix`: fetchPrefix's result, when the file was read that way.
export function jobSpec(glb, { url, headers, lod = -1, loss = 0, seed = 1, session = null, prefix = null, view = null }) {
  const prims = progressivePrimitives(glb);
  const streams = prims.map((p) => ({ streamId: p.streamId, base: p.base.slice(), ids: p.ids }));
  let source;
  if (session) {
    source = Object.assign({ kind: 'session' }, session);
  } else if (prims.every((p) => p.blob !== null)) {
    source = { kind: 'bytes', blobs: prims.map((p) => ({ streamId: p.streamId, bytes: p.blob.slice() })) };
  } else {
    // The bytes the prefix's reads already hold beyond the first blob's start
    // go with the job; the ranged GET of the blobs starts after them.
    const blobs = prims.map((p) => ({ streamId: p.streamId, start: p.blobRange.start, end: p.blobRange.end }));
    const first = Math.min(...blobs.map((b) => b.start));
    const have = prefix ? prefix.bytes.byteLength : first;
    source = { kind: 'ranges', url: new URL(url, self.location.href).href, headers: headers || {}, blobs,
               head: have > first ? prefix.bytes.slice(first, have) : new Uint8Array(0), headStart: first };
    // A view: the streams it needs first, a ranged GET each (view_order.js).
    if (view) source.order = viewOrder(glb.json, prims, view);
  }
  return { prims, spec: { streams, source, lod, loss, seed } };
}

export class MeshstreamClient {
  constructor() {
    this.listeners = {};
    this.primitives = [];
    this.worker = null;
    this.ownWorker = false;
    this.job = null;
    this.abort = new AbortController();
    this.timings = { opened: performance.now(), base: null, complete: null };
  }

  on(name, fn) {
    (this.listeners[name] = this.listeners[name] || []).push(fn);
    return this;
  }

  emit(name, arg) {
    for (const fn of this.listeners[name] || []) fn(arg);
  }

  // Options: url, headers, lod (-1: all), session, loss and seed (a
  // simulated loss, to watch predictions), worker (a DecoderWorker to share).
  static async open(options) {
    const client = new MeshstreamClient();
    const prefix = await fetchPrefix(options.url, { headers: options.headers, signal: client.abort.signal });
    client.glb = prefix.glb;
    client.prefix = prefix;
    client.worker = options.worker || new DecoderWorker(options);
    client.ownWorker = !options.worker;
    await client.worker.ready;
    const { prims, spec } = jobSpec(prefix.glb, Object.assign({}, options, { prefix }));
    client.primitives = prims.map((p) => ({ streamId: p.streamId, mesh: p.mesh, primitive: p.primitive, level: 0,
                                             levels: 0, arrays: null }));
    let bases = 0;
    client.job = client.worker.open(spec, (msg) => {
      const prim = client.primitives[msg.streamId];
      if (msg.type === 'base') {
        prim.arrays = msg.mesh;
        if (++bases === client.primitives.length) {
          client.timings.base = performance.now();
          client.emit('base');
        }
      } else if (msg.type === 'level') {
        prim.arrays = msg.mesh;
        prim.level = msg.level;
        prim.levels = msg.levels;
        client.emit('level', msg);
        client.worker.ack(msg.job, msg.streamId);
      } else if (msg.type === 'complete') {
        client.timings.complete = performance.now();
        client.emit('complete', msg.stats);
      } else if (msg.type === 'error') {
        client.emit('error', new Error(msg.message));
      }
    });
    return client;
  }

  dispose() {
    this.abort.abort();
    if (this.worker && this.job !== null) this.worker.close(this.job);
    if (this.worker && this.ownWorker) this.worker.terminate();
    this.worker = null;
    this.primitives = [];
    this.listeners = {};
  }
}
