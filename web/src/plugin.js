// three.js integration (docs/design/web.md): a GLTFLoader plugin that refines the
// progressive primitives of a .glb in place.
//
//   import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
//   import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
//   import { MeshstreamProgressive } from '@meshstream/web/plugin';
//
//   const progressive = new MeshstreamProgressive({ headers, lod, session });
//   const loader = new GLTFLoader().setDRACOLoader(new DRACOLoader().setDecoderPath(...));
//   loader.register((parser) => progressive.plugin(parser));
//   const gltf = await progressive.load(loader, url);  // the base, from one or two ranged GETs
//   scene.add(gltf.scene);
//   progressive.addEventListener('level', (e) => ...);  // e.streamId, e.level, e.levels, e.vertices, e.faces
//   progressive.addEventListener('complete', (e) => ...);
//   // each frame: a live session sends the camera (at most every viewIntervalMs, when it moved)
//   progressive.setView(camera, renderer.domElement.width, renderer.domElement.height);
//   progressive.dispose();  // stops the download or session; frees the worker's decoders
//
// The base is what GLTFLoader (with DRACOLoader) shows of the file's prefix;
// the worker decodes the refinements as their bytes arrive (worker.js) and
// posts each level. The first level replaces each progressive geometry's
// attributes and index by ones sized for the finest level (its vertex count
// from the stream header; its index count bounded by six per split); every
// later level is copied into them, with `needsUpdate` and the draw range: no
// new objects per level. A geometry several meshes share is updated once.
// `loader.loadAsync(url)` of the whole file works too: the blobs are then
// read from memory. Events: 'base', 'level', 'complete', 'error'.
// `tintPredicted`: vertices the decoder predicted (a simulated `loss`, or a
// lossy transport) are shown orange through vertex colours.

import { BufferAttribute, EventDispatcher, Matrix4 } from 'three';
import { DecoderWorker, fetchPrefix, jobSpec } from './client.js';

const UV_NAMES = ['uv', 'uv1', 'uv2', 'uv3'];

// A three.js camera as a View (docs/spec/streaming-protocol.md, "Views"):
// the eye, projection x view (column-major, as three.js stores matrices),
// the viewport in pixels. For options.view and setView.
export function viewOfCamera(camera, width, height) {
  camera.updateMatrixWorld();
  const vp = new Matrix4().multiplyMatrices(camera.projectionMatrix, camera.matrixWorldInverse).elements;
  const w = camera.matrixWorld.elements;
  return { camera: [w[12], w[13], w[14]], viewProjection: Array.from(vp),
           width: Math.max(1, Math.round(width)), height: Math.max(1, Math.round(height)) };
}

// A job's spec split into `count` specs of about as many streams each
// (round-robin in the view's order, or the streams' own), each reading only
// its streams' blobs (a ranged GET per blob, in that order).
function splitSpec(spec, count) {
  if (count <= 1) return [spec];
  const source = spec.source;
  const order = Array.isArray(source.order) ? source.order : spec.streams.map((s) => s.streamId);
  const groups = Array.from({ length: count }, () => []);
  order.forEach((id, i) => groups[i % count].push(id));
  return groups.filter((g) => g.length > 0).map((ids) => {
    const set = new Set(ids);
    const part = Object.assign({}, spec, { streams: spec.streams.filter((s) => set.has(s.streamId)) });
    part.source = Object.assign({}, source, { blobs: source.blobs.filter((b) => set.has(b.streamId)) });
    if (source.kind === 'ranges') part.source.order = ids;
    return part;
  });
}

// The workers' 'complete' stats as one: counts and times added, the
// longest worker's time, the per-stream maps joined.
function mergeStats(list) {
  const out = { bytes: 0, dropped: 0, baseMs: 0, decodeMs: 0, workerMs: 0, predictedVertices: {} };
  for (const s of list) {
    out.bytes += s.bytes || 0;
    out.dropped += s.dropped || 0;
    out.baseMs += s.baseMs || 0;
    out.decodeMs += s.decodeMs || 0;
    out.workerMs = Math.max(out.workerMs, s.workerMs || 0);
    Object.assign(out.predictedVertices, s.predictedVertices || {});
    if (Array.isArray(s.viewOrder)) out.viewOrder = (out.viewOrder || []).concat(s.viewOrder);
    for (const [key, value] of Object.entries(s)) if (!(key in out)) out[key] = value;
  }
  return out;
}

export class MeshstreamProgressive extends EventDispatcher {
  constructor(options = {}) {
    super();
    this.options = options;
    this.worker = options.worker || null;
    this.ownWorker = !options.worker;
    this.extraWorkers = [];  // made here when options.workers asks for more than one
    this.jobs = [];  // { worker, id }
    this.pending = null;  // the prefix load() fetched, for the next afterRoot
    this.geometries = new Map();  // streamId -> { geometry, meshes, capacity }
    this.stats = { levels: 0, bytes: 0, viewsSent: 0 };  // bytes: the prefix's and the blobs' (or the session's)
    this.lastView = null;     // the last view sent, and when
    this.lastViewAt = -Infinity;
    this.prefixBytes = 0;
    this.timings = { start: performance.now(), base: null, complete: null };
    this.complete = new Promise((resolve, reject) => {
      this.resolveComplete = resolve;
      this.rejectComplete = reject;
    });
    this.complete.catch(() => {});  // reported through 'error' as well
  }

  // For GLTFLoader.register.
  plugin(parser) {
    return { name: 'MESHSTREAM_progressive', afterRoot: (result) => this.afterRoot(parser, result) };
  }

  // Reads the file's prefix by HTTP ranges and parses it with `loader` (on
  // which plugin() is registered): the scene at its base level.
  async load(loader, url) {
    this.timings.start = performance.now();
    const prefix = await fetchPrefix(url, { headers: this.options.headers });
    this.pending = { url, prefix };
    this.prefixBytes = prefix.bytes.byteLength;
    const buffer = prefix.bytes.buffer.slice(prefix.bytes.byteOffset, prefix.bytes.byteOffset + prefix.bytes.byteLength);
    const base = new URL('.', new URL(url, self.location.href)).href;
    const gltf = await loader.parseAsync(buffer, base);
    this.timings.base = performance.now();
    this.dispatchEvent({ type: 'base', gltf });
    return gltf;
  }

  async afterRoot(parser, result) {
    const used = parser.json.extensionsUsed || [];
    if (!used.includes('MESHSTREAM_progressive')) return;
    const pending = this.pending;
    this.pending = null;
    const body = parser.extensions.KHR_binary_glTF ? parser.extensions.KHR_binary_glTF.body : null;
    const glb = {
      json: parser.json,
      bin: body ? new Uint8Array(body) : null,
      binOffset: pending ? pending.prefix.glb.binOffset : -1,
    };
    // options.view: a view, or a function of the base scene that returns one
    // (the page frames its camera on it): the HTTP-range path fetches the
    // streams it needs first before the others (view_order.js).
    const view = typeof this.options.view === 'function' ? this.options.view(result) : this.options.view || null;
    const { prims, spec } = jobSpec(glb, Object.assign({}, this.options, { url: pending ? pending.url : null,
                                                                          prefix: pending ? pending.prefix : null,
                                                                          view }));
    if (prims.length === 0) return;
    if (spec.source.kind === 'ranges' && !pending) throw new Error('MeshstreamProgressive: the blobs are not in memory');
    // Each progressive primitive's geometry, through GLTFLoader's associations.
    const byPlace = new Map(prims.map((p) => [p.mesh + '/' + p.primitive, p.streamId]));
    for (const root of result.scenes || [result.scene]) {
      root.traverse((object) => {
        if (!object.isMesh) return;
        const a = parser.associations.get(object);
        if (!a || a.meshes === undefined) return;
        const streamId = byPlace.get(a.meshes + '/' + (a.primitives || 0));
        if (streamId === undefined) return;
        const entry = this.geometries.get(streamId) || { geometry: object.geometry, meshes: [], capacity: null };
        entry.meshes.push(object);
        this.geometries.set(streamId, entry);
      });
    }
    if (!this.worker) this.worker = new DecoderWorker(this.options);
    // options.workers (default 1): the streams of a file (a scene's
    // primitives, a large mesh's spatial parts) split among that many Web
    // Workers, each decoding its own; a live session stays on one.
    const count = spec.source.kind === 'session' ? 1 : Math.max(1, Math.min(this.options.workers || 1, spec.streams.length));
    while (this.extraWorkers.length < count - 1) this.extraWorkers.push(new DecoderWorker(this.options));
    const workers = [this.worker, ...this.extraWorkers.slice(0, count - 1)];
    await Promise.all(workers.map((w) => w.ready));
    const specs = splitSpec(spec, count);
    const group = { left: specs.length, bytes: new Array(specs.length).fill(0), stats: [] };
    this.stats.workers = specs.length;
    specs.forEach((s, k) => {
      const worker = workers[k];
      this.jobs.push({ worker, id: worker.open(s, (msg) => this.onMessage(msg, worker, k, group)) });
    });
  }

  onMessage(msg, worker, k, group) {
    if (msg.type === 'level') {
      const entry = this.geometries.get(msg.streamId);
      if (entry) this.applyLevel(entry, msg);
      this.stats.levels += 1;
      group.bytes[k] = msg.bytes;
      this.stats.bytes = this.prefixBytes + group.bytes.reduce((a, b) => a + b, 0);
      this.dispatchEvent({ type: 'level', streamId: msg.streamId, level: msg.level, levels: msg.levels,
                           vertices: msg.mesh.vertices, faces: msg.mesh.indices.length / 3,
                           predictedVertices: msg.mesh.predictedVertices, hash: msg.hash });
      // The next level once this one is copied into the geometry: levels
      // that come faster than frames replace each other in the buffers (the
      // next frame shows the newest), and the worker never queues more than
      // one per stream.
      if (this.worker) worker.ack(msg.job, msg.streamId);
    } else if (msg.type === 'complete') {
      group.stats[k] = msg.stats;
      if (--group.left > 0) return;
      for (const entry of this.geometries.values()) this.updateBounds(entry);
      this.timings.complete = performance.now();
      Object.assign(this.stats, mergeStats(group.stats));
      this.stats.bytes += this.prefixBytes;
      this.dispatchEvent({ type: 'complete', stats: this.stats, timings: this.timings });
      this.resolveComplete(this.stats);
    } else if (msg.type === 'error') {
      const error = new Error(msg.message);
      this.dispatchEvent({ type: 'error', error });
      this.rejectComplete(error);
    }
  }

  // What the camera sees, for a live session (docs/spec/streaming-protocol.md,
  // "Views"): the server sends first the refinements that span the most
  // pixels of it. Call it every frame: it sends when the camera moved (or
  // the viewport changed) and `viewIntervalMs` (default 250; the server acts
  // on one a second) have passed since the last one. Returns whether it sent.
  setView(camera, width, height) {
    if (!this.worker || this.jobs.length === 0 || !this.options.session) return false;
    const now = performance.now();
    const interval = this.options.viewIntervalMs === undefined ? 250 : this.options.viewIntervalMs;
    if (now - this.lastViewAt < interval) return false;
    const view = viewOfCamera(camera, width, height);
    const last = this.lastView;
    if (last && last.width === view.width && last.height === view.height &&
        last.viewProjection.every((x, i) => Math.abs(x - view.viewProjection[i]) <= 1e-6 * (1 + Math.abs(x)))) {
      return false;
    }
    this.lastView = view;
    this.lastViewAt = now;
    for (const job of this.jobs) job.worker.view(job.id, view);
    this.stats.viewsSent += 1;
    return true;
  }

  // Attributes sized for the finest level, made once per geometry.
  allocate(entry, msg) {
    const g = entry.geometry;
    const cap = msg.capacity;
    const m = msg.mesh;
    const make = (name, itemSize) => g.setAttribute(name, new BufferAttribute(new Float32Array(cap.vertices * itemSize), itemSize));
    make('position', 3);
    if (m.normals) make('normal', 3);
    m.texcoords.forEach((t, k) => { if (k < UV_NAMES.length) make(UV_NAMES[k], 2); });
    const colorSize = g.getAttribute('color') ? g.getAttribute('color').itemSize : 4;
    if (m.colors || this.options.tintPredicted) make('color', m.colors ? colorSize : 3);
    g.setIndex(new BufferAttribute(new Uint32Array(cap.indices), 1));
    if (this.options.tintPredicted) for (const mesh of entry.meshes) {
      for (const mat of [].concat(mesh.material)) {
        mat.vertexColors = true;
        mat.needsUpdate = true;
      }
    }
    entry.capacity = cap;
  }

  applyLevel(entry, msg) {
    const m = msg.mesh;
    if (entry.capacity === null || m.vertices > entry.capacity.vertices || m.indices.length > entry.capacity.indices) {
      // The capacity is the header's: a level beyond it is a decoder bug, met
      // with a larger allocation rather than a broken picture.
      if (entry.capacity !== null) {
        msg.capacity = { vertices: Math.max(m.vertices, entry.capacity.vertices), indices: Math.max(m.indices.length, entry.capacity.indices) };
      }
      this.allocate(entry, msg);
    }
    const g = entry.geometry;
    const put = (name, data, from, to) => {
      const attr = g.getAttribute(name);
      if (!attr || !data) return;
      if (from === to) {
        attr.array.set(data);
      } else {
        for (let v = 0; v < m.vertices; ++v) for (let c = 0; c < to; ++c) attr.array[v * to + c] = data[v * from + c];
      }
      attr.needsUpdate = true;
    };
    put('position', m.positions, 3, 3);
    put('normal', m.normals, 3, 3);
    m.texcoords.forEach((t, k) => { if (k < UV_NAMES.length) put(UV_NAMES[k], t, 2, 2); });
    if (m.colors) put('color', m.colors, 4, g.getAttribute('color').itemSize);
    if (this.options.tintPredicted) this.tint(g, m);
    g.index.array.set(m.indices);
    g.index.needsUpdate = true;
    g.setDrawRange(0, m.indices.length);
    if (msg.level === 1) this.updateBounds(entry, m.vertices);
    entry.vertices = m.vertices;
  }

  // Predicted vertices orange, the others as they are (white without colours).
  tint(g, m) {
    const color = g.getAttribute('color');
    const k = color.itemSize;
    for (let v = 0; v < m.vertices; ++v) {
      const exact = !m.reliable || m.reliable[v] !== 0;
      if (!m.colors) {
        color.array[v * k] = 1;
        color.array[v * k + 1] = exact ? 1 : 0.45;
        color.array[v * k + 2] = exact ? 1 : 0.1;
      } else if (!exact) {
        color.array[v * k + 1] *= 0.45;
        color.array[v * k + 2] *= 0.1;
      }
    }
    color.needsUpdate = true;
  }

  // The bounds of the vertices in use (the arrays are larger).
  updateBounds(entry, vertices = entry.vertices) {
    const g = entry.geometry;
    const pos = g.getAttribute('position');
    if (!pos || !vertices) return;
    if (!g.boundingBox) g.computeBoundingBox();
    const box = g.boundingBox.makeEmpty();
    const p = pos.array;
    for (let v = 0; v < vertices; ++v) {
      box.expandByPoint({ x: p[3 * v], y: p[3 * v + 1], z: p[3 * v + 2] });
    }
    if (!g.boundingSphere) g.computeBoundingSphere();
    box.getCenter(g.boundingSphere.center);
    let r2 = 0;
    const c = g.boundingSphere.center;
    for (let v = 0; v < vertices; ++v) {
      const dx = p[3 * v] - c.x, dy = p[3 * v + 1] - c.y, dz = p[3 * v + 2] - c.z;
      r2 = Math.max(r2, dx * dx + dy * dy + dz * dz);
    }
    g.boundingSphere.radius = Math.sqrt(r2);
  }

  // Stops every download or session and frees the worker's decoders (and
  // the worker, when this object made it). With `geometries`, disposes the
  // refined geometries too (their GPU buffers).
  dispose({ geometries = false } = {}) {
    for (const job of this.jobs) job.worker.close(job.id);
    if (this.worker && this.ownWorker) this.worker.terminate();
    for (const w of this.extraWorkers) w.terminate();
    this.worker = null;
    this.extraWorkers = [];
    this.jobs = [];
    if (geometries) for (const entry of this.geometries.values()) entry.geometry.dispose();
    this.geometries.clear();
  }
}
