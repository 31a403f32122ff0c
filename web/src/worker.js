// The decoding side of the browser (docs/design/web.md): a module Web Worker that
// holds the wasm decoder (codec/ compiled by emscripten) and draco3d, so
// that no decoding runs on the page's thread. client.js starts it and talks
// to it with messages:
//
//   page -> worker
//     { type: 'open', job, streams, source, lod, loss, seed }
//         streams: per refined primitive { streamId, base (Draco bytes), ids }
//         source:  { kind: 'ranges', url, headers, blobs: [{ streamId, start, end }], head, headStart,
//                    order (optional: stream ids, the view's first; a GET per blob in that order) }
//                    (file offsets of each stream blob, end exclusive; `head`: the
//                    file's bytes from headStart the page already read)
//                  { kind: 'bytes', blobs: [{ streamId, bytes }] }  (the file already in memory)
//                  { kind: 'session', ... }                         (session.js)
//         loss:    a share of the datagrams to drop, to watch predictions (0: none)
//     { type: 'ack', job, streamId }   the page took the stream's last level: the next may go
//     { type: 'close', job }
//   worker -> page
//     { type: 'ready' }                                  the modules are loaded
//     { type: 'base', job, streamId, mesh }              the base as draco3d decoded it
//     { type: 'level', job, streamId, level, levels, mesh, capacity, bytes }
//     { type: 'complete', job, stats }
//     { type: 'error', job, message }
//   mesh: { vertices, positions, normals, texcoords[], colors, indices,
//           reliable, predictedVertices } (transferred, not copied);
//   capacity: { vertices, indices } of the finest level (for preallocation).
// At most one level per stream is on its way to the page: levels decoded
// while the page has not acknowledged the last one are not posted, only the
// newest when the acknowledgement comes (a page that draws slowly sees
// fewer levels, never a backlog, and the finest one as soon as it can).
// 'complete' follows the last level of every stream.
//
// The glue scripts of the two wasm modules are classic scripts, loaded into
// this module worker by fetch and an indirect eval (a module worker has no
// importScripts). Their URLs come from the page (client.js) or default to the
// bundle's layout beside this file.

import { decodeDracoBase } from './draco_base.js';
import { LiveDecoder } from './decoder.js';
import { BlobReader } from './blob_reader.js';
import { openSessionSource } from './session.js';

let modules = null;  // { M, D } once loaded
const jobs = new Map();  // job -> Job

async function loadClassicScript(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(url + ': HTTP ' + response.status);
  const text = await response.text();
  (0, eval)(text + '\n//# sourceURL=' + url);
}

async function loadModules(urls) {
  const here = (path) => new URL(path, import.meta.url).href;
  const decoderUrl = urls.decoder || here('../wasm/meshstream_decoder.cjs');
  const dracoUrl = urls.draco || here('../vendor/draco3d/draco_decoder_nodejs.js');
  const dracoWasmUrl = urls.dracoWasm || here('../vendor/draco3d/draco_decoder.wasm');
  await loadClassicScript(decoderUrl);
  await loadClassicScript(dracoUrl);
  const wasmResponse = await fetch(dracoWasmUrl);
  if (!wasmResponse.ok) throw new Error(dracoWasmUrl + ': HTTP ' + wasmResponse.status);
  const wasmBinary = await wasmResponse.arrayBuffer();
  const [M, D] = await Promise.all([
    self.createMeshstreamDecoder(),
    self.DracoDecoderModule({ wasmBinary }),
  ]);
  // The decoder's hot code compiled before the first stream (docs/design/web.md,
  // "Warming the decoder"): a sphere encoded and decoded in the module.
  if (M._ms_wasm_warm_up() === 0) throw new Error('the decoder failed its warm-up decode');
  return { M, D };
}

function transferables(mesh) {
  const out = [mesh.positions.buffer, mesh.indices.buffer];
  if (mesh.normals) out.push(mesh.normals.buffer);
  if (mesh.colors) out.push(mesh.colors.buffer);
  if (mesh.reliable) out.push(mesh.reliable.buffer);
  for (const t of mesh.texcoords) out.push(t.buffer);
  return out;
}

// A small deterministic generator for the viewer's simulated loss.
function lossGenerator(loss, seed) {
  let x = (seed >>> 0) || 1;
  return () => {
    x ^= x << 13;
    x >>>= 0;
    x ^= x >>> 17;
    x ^= x << 5;
    x >>>= 0;
    return x / 4294967296 < loss;
  };
}

// One stream's decoding: the base, then the stream's pieces in order.
class StreamJob {
  constructor(job, spec, base, lod, drop) {
    this.job = job;
    this.streamId = spec.streamId;
    this.baseBytes = spec.base;  // the Draco bytes (a session's must equal them)
    this.base = base;
    this.lod = lod;
    this.drop = drop;
    this.live = null;
    this.applied = 0;     // refinements decoded
    this.shown = -1;      // the level last posted
    this.inFlight = false;
    this.posted = false;
    this.dropped = new Set();  // refinements with a dropped datagram
    this.reader = new BlobReader();
  }

  // A piece of the stream (BlobReader's events, or a session's messages).
  take(e) {
    if (this.job.closed) return;
    const t0 = performance.now();
    try {
      this.takeNow(e);
    } finally {
      this.job.stats.decodeMs += performance.now() - t0;
    }
  }

  takeNow(e) {
    if (e.kind === 'header') {
      this.live = new LiveDecoder(modules.M, e.bytes, this.streamId, this.lod);
      this.live.setBase(this.base);
      this.levels = this.lod < 0 ? this.live.refinements : Math.min(this.lod, this.live.refinements);
      return;
    }
    if (this.live === null) throw new Error('stream ' + this.streamId + ': data before its header');
    if (e.kind === 'control') {
      if (e.refinement < this.levels) this.live.control(e.bytes);
    } else if (e.kind === 'datagram') {
      if (this.drop && this.drop()) {
        this.dropped.add(e.refinement);
        this.job.stats.dropped += 1;
        return;
      }
      this.live.datagram(e.bytes);
    } else if (e.kind === 'end') {
      this.live.end(e.refinement, e.datagrams);
      if (this.dropped.has(e.refinement)) this.live.declare(e.refinement);
      this.advance(this.live.poll());
    }
  }

  // Records the refinements applied and posts the newest level unless one
  // is on its way (a level per refinement; several that became ready
  // together post the last).
  advance(applied, always = false) {
    if (applied <= this.applied && !always) return;
    this.applied = applied;
    this.post(always);
  }

  // The newest level, unless the page has not taken the last one yet.
  post(always = false) {
    if (this.inFlight || this.live === null || (this.shown === this.applied && !always)) return;
    this.shown = this.applied;
    this.inFlight = true;
    this.posted = true;
    this.live.snapshot();
    const mesh = this.live.arrays();
    this.job.stats.predictedVertices[this.streamId] = mesh.predictedVertices;
    postMessage({
      type: 'level', job: this.job.id, streamId: this.streamId, level: this.applied, levels: this.levels, mesh,
      hash: this.live.hash(),
      capacity: { vertices: this.live.finalVertices, indices: this.base.indices.length + 6 * this.live.splits },
      bytes: this.job.stats.bytes,
    }, transferables(mesh));
  }

  // The page took the last level.
  ack() {
    this.inFlight = false;
    this.post();
    this.job.maybeComplete();
  }

  // Every piece is in: the last refinements decoded (and a stream without
  // refinements posts its base as its only level).
  finish() {
    if (this.live === null) throw new Error('stream ' + this.streamId + ': no header arrived');
    this.advance(this.live.flush(), !this.posted);
    if (this.applied < this.levels) {
      throw new Error('stream ' + this.streamId + ': ' + this.applied + ' of ' + this.levels + ' refinements arrived');
    }
    this.finished = true;
  }

  // Its last level posted and taken.
  done() {
    return this.finished && !this.inFlight && this.shown === this.applied;
  }

  close() {
    if (this.live) this.live.close();
    this.live = null;
  }
}

class Job {
  constructor(id) {
    this.id = id;
    this.closed = false;
    this.abort = new AbortController();
    this.streams = new Map();
    // bytes; datagrams dropped by the simulated loss; per stream the
    // predicted vertices; and where the worker's time went (ms): the bases
    // (draco3d), the stream's pieces (the wasm decoder, the snapshots and
    // posts), and the whole job (workerMs, to the last level taken).
    this.stats = { bytes: 0, dropped: 0, predictedVertices: {}, baseMs: 0, decodeMs: 0 };
  }

  close() {
    this.closed = true;
    this.abort.abort();
    for (const s of this.streams.values()) s.close();
  }

  // 'complete' once every stream is finished and its last level taken.
  maybeComplete() {
    if (!this.finishing || this.closed || this.completed) return;
    for (const s of this.streams.values()) if (!s.done()) return;
    this.completed = true;
    this.stats.workerMs = performance.now() - this.started;
    postMessage({ type: 'complete', job: this.id, stats: this.stats });
    this.close();
    jobs.delete(this.id);
  }
}

// Bytes [at, at + n) of the file to the reader of each stream whose blob
// they overlap; returns at + n.
function dispatcher(job, blobs) {
  return (value, at) => {
    const chunkEnd = at + value.byteLength;
    for (const b of blobs) {
      const lo = Math.max(at, b.start), hi = Math.min(chunkEnd, b.end);
      if (lo >= hi) continue;
      const s = job.streams.get(b.streamId);
      for (const e of s.reader.push(value.subarray(lo - at, hi - at))) s.take(e);
    }
    return chunkEnd;
  };
}

// One ranged GET of the file's bytes [from, to), each chunk to `dispatch`.
async function fetchRange(job, source, from, to, dispatch) {
  const headers = Object.assign({}, source.headers || {}, { Range: `bytes=${from}-${to - 1}` });
  const response = await fetch(source.url, { headers, signal: job.abort.signal });
  if (response.status !== 206 && response.status !== 200) {
    let detail = '';
    try { detail = (await response.json()).error || ''; } catch (e) { /* not JSON */ }
    throw new Error(`${source.url}: HTTP ${response.status}${detail ? ' (' + detail + ')' : ''}`);
  }
  // A server that ignores ranges sends the whole file from byte 0: what
  // comes before `from` is skipped.
  let skip = response.status === 206 ? 0 : from;
  let at = from;
  const body = response.body.getReader();
  for (;;) {
    const { done, value } = await body.read();
    if (done) break;
    job.stats.bytes += value.byteLength;
    let chunk = value;
    if (skip > 0) {
      const n = Math.min(skip, chunk.byteLength);
      skip -= n;
      chunk = chunk.subarray(n);
      if (chunk.byteLength === 0) continue;
    }
    if (at + chunk.byteLength > to) chunk = chunk.subarray(0, to - at);
    at = dispatch(chunk, at);
    if (at >= to) break;
  }
  if (at < to) throw new Error(`${source.url}: the response ended at byte ${at} of ${to}`);
}

// The blobs' bytes after those the prefix already held (`head`): one ranged
// GET of all of them (they lie together at the end of the file, in stream
// order), or, with a view (source.order: the streams it needs first,
// view_order.js), one per stream blob in that order.
async function readRanges(job, source) {
  const blobs = [...source.blobs].sort((a, b) => a.start - b.start);
  const dispatch = dispatcher(job, blobs);
  let at = blobs[0].start;
  if (source.head && source.head.byteLength > 0) at = dispatch(source.head, source.headStart);
  if (!Array.isArray(source.order)) {
    const last = blobs[blobs.length - 1].end;
    if (at < last) await fetchRange(job, source, at, last, dispatch);
    return;
  }
  const byId = new Map(blobs.map((b) => [b.streamId, b]));
  for (const id of source.order) {
    const b = byId.get(id);
    if (!b) continue;
    const from = Math.max(b.start, Math.min(at, b.end));
    if (from < b.end) await fetchRange(job, source, from, b.end, dispatch);
  }
  job.stats.viewOrder = source.order;
}

function readBytes(job, source) {
  for (const b of source.blobs) {
    const s = job.streams.get(b.streamId);
    job.stats.bytes += b.bytes.byteLength;
    for (const e of s.reader.push(b.bytes)) s.take(e);
  }
}

async function open(msg) {
  const job = new Job(msg.job);
  jobs.set(job.id, job);
  job.started = performance.now();
  job.stats.source = msg.source.kind;  // 'ranges', 'bytes' (the prefix held every blob) or 'session'
  try {
    if (modules === null) throw new Error('the decoder modules are not loaded');
    const lod = msg.lod === undefined ? -1 : msg.lod;
    // The simulated loss applies to a file's datagrams (a session's transport decides its own).
    const drop = msg.loss > 0 && msg.source.kind !== 'session' ? lossGenerator(msg.loss, msg.seed || 1) : null;
    for (const spec of msg.streams) {
      const t0 = performance.now();
      const base = decodeDracoBase(modules.D, spec.base, spec.ids);
      job.stats.baseMs += performance.now() - t0;
      job.streams.set(spec.streamId, new StreamJob(job, spec, base, lod, drop));
      const copy = {
        vertices: base.vertices, positions: base.positions.slice(), normals: base.normals && base.normals.slice(),
        texcoords: base.texcoords.map((t) => t.slice()), colors: base.colors && base.colors.slice(),
        indices: base.indices.slice(), reliable: null, predictedVertices: 0,
      };
      postMessage({ type: 'base', job: job.id, streamId: spec.streamId, mesh: copy }, transferables(copy));
    }
    if (msg.source.kind === 'ranges') {
      await readRanges(job, msg.source);
    } else if (msg.source.kind === 'bytes') {
      readBytes(job, msg.source);
    } else if (msg.source.kind === 'session') {
      await openSessionSource(job, msg.source, (streamId, e) => job.streams.get(streamId).take(e));
    } else {
      throw new Error('unknown source ' + msg.source.kind);
    }
    if (job.closed) return;
    for (const s of job.streams.values()) s.finish();
    job.finishing = true;
    job.maybeComplete();  // or at the last acknowledgement
  } catch (e) {
    if (!job.closed) postMessage({ type: 'error', job: job.id, message: String(e && e.message ? e.message : e) });
    job.close();
    jobs.delete(job.id);
  }
}

self.onmessage = (event) => {
  const msg = event.data;
  if (msg.type === 'init') {
    loadModules(msg.urls || {}).then(
      (m) => {
        modules = m;
        postMessage({ type: 'ready' });
      },
      (e) => postMessage({ type: 'error', job: null, message: 'loading the decoder: ' + (e.message || e) }));
  } else if (msg.type === 'open') {
    open(msg);
  } else if (msg.type === 'ack') {
    const job = jobs.get(msg.job);
    const stream = job && !job.closed ? job.streams.get(msg.streamId) : null;
    if (stream) {
      try {
        stream.ack();
      } catch (e) {
        postMessage({ type: 'error', job: job.id, message: String(e && e.message ? e.message : e) });
        job.close();
        jobs.delete(job.id);
      }
    }
  } else if (msg.type === 'view') {
    // The page's camera: to the live session (before it opens, its first view).
    const job = jobs.get(msg.job);
    if (job && !job.closed) {
      if (job.sendView) job.sendView(msg.view);
      else job.view = msg.view;
    }
  } else if (msg.type === 'close') {
    const job = jobs.get(msg.job);
    if (job) job.close();
  }
};
