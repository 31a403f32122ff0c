// One primitive's progressive stream decoded by the wasm module
// (web/wasm/decoder_api.h), the result as typed arrays copied out of the
// module's memory. StreamDecoder decodes a whole blob (with a simulated
// loss, as `meshstream decode --loss`); LiveDecoder takes the stream piece by
// piece as a session or a file read by ranges delivers it. Both take the base
// as draco3d decoded it (draco_base.js). Every failure throws an Error with
// the decoder's message.

class WasmStream {
  constructor(M) {
    this.M = M;
    this.s = 0;
  }

  error() {
    return this.M.UTF8ToString(this.M._ms_wasm_error(this.s));
  }

  check(ok, what) {
    if (!ok) throw new Error(what + ': ' + this.error());
  }

  // Copies a typed array into the module's heap; the caller frees it.
  copyIn(array, elementBytes) {
    if (!array) return 0;
    const bytes = array.byteLength;
    const p = this.M._malloc(Math.max(bytes, elementBytes));
    this.M.HEAPU8.set(new Uint8Array(array.buffer, array.byteOffset, bytes), p);
    return p;
  }

  // The base's arrays in the module's heap, handed to `call` (set_base or
  // live_set_base), then freed.
  passBase(base, call) {
    const sets = base.texcoords.length;
    const texcoords = new Float32Array(sets * 2 * base.vertices);
    base.texcoords.forEach((t, k) => texcoords.set(t, k * 2 * base.vertices));
    const ptrs = [
      this.copyIn(base.positions, 4),
      this.copyIn(base.normals, 4),
      sets > 0 ? this.copyIn(texcoords, 4) : 0,
      this.copyIn(base.colors, 4),
      this.copyIn(base.indices, 4),
    ];
    const rc = call(this.s, base.vertices, ptrs[0], ptrs[1], sets, ptrs[2], ptrs[3], base.indices.length, ptrs[4]);
    for (const p of ptrs) if (p) this.M._free(p);
    this.check(rc === 0, 'base');
  }

  hash() {
    return this.M.UTF8ToString(this.M._ms_wasm_hash(this.s));
  }

  // The decoded mesh: counts, float arrays per attribute, indices, and per
  // vertex 1 when exact, 0 when predicted (or placed from a predicted one).
  arrays() {
    const M = this.M, s = this.s;
    const n = M._ms_wasm_vertex_count(s), ni = M._ms_wasm_index_count(s);
    const floats = (p, k) => (p ? new Float32Array(M.HEAPU8.buffer, p, k * n).slice() : null);
    const texcoords = [];
    for (let t = 0; t < M._ms_wasm_texcoord_sets(s); ++t) texcoords.push(floats(M._ms_wasm_texcoords(s, t), 2));
    const ip = M._ms_wasm_indices(s);
    const rp = M._ms_wasm_reliable(s);
    return {
      vertices: n,
      positions: floats(M._ms_wasm_positions(s), 3),
      normals: floats(M._ms_wasm_normals(s), 3),
      texcoords,
      colors: floats(M._ms_wasm_colors(s), 4),
      indices: ip ? new Uint32Array(M.HEAPU8.buffer, ip, ni).slice() : new Uint32Array(0),
      reliable: rp ? new Uint8Array(M.HEAPU8.buffer, rp, n).slice() : null,
      predictedVertices: M._ms_wasm_predicted_vertices(s),
    };
  }

  close() {
    if (this.s) this.M._ms_wasm_close(this.s);
    this.s = 0;
  }
}

export class StreamDecoder extends WasmStream {
  constructor(M, blob, streamId) {
    super(M);
    const p = this.copyIn(blob, 1);
    this.s = M._ms_wasm_open(p, blob.byteLength, streamId);
    M._free(p);
    if (this.s === 0) throw new Error('out of memory');
    this.check(this.error() === '', 'open');
  }

  setBase(base) {
    this.passBase(base, this.M._ms_wasm_set_base);
  }

  decode({ lod = -1, loss = 0, burst = 0, seed = 1, reliable = [] } = {}) {
    const r = this.copyIn(Uint32Array.from(reliable), 4);
    const rc = this.M._ms_wasm_decode(this.s, lod, loss, burst, seed, r, reliable.length);
    this.M._free(r);
    this.check(rc === 0, 'decode');
  }

}

export class LiveDecoder extends WasmStream {
  // `header`: the stream header's bytes; `lod`: refinements to decode (-1: all).
  constructor(M, header, streamId, lod = -1) {
    super(M);
    const p = this.copyIn(header, 1);
    this.s = M._ms_wasm_live_open(p, header.byteLength, streamId, lod);
    M._free(p);
    if (this.s === 0) throw new Error('out of memory');
    this.check(this.error() === '', 'open');
    this.refinements = M._ms_wasm_refinements(this.s);
    this.finalVertices = M._ms_wasm_live_final_vertices(this.s);
    let splits = 0;
    for (let r = 0; r < this.refinements; ++r) splits += M._ms_wasm_live_splits(this.s, r);
    this.splits = splits;
  }

  setBase(base) {
    this.passBase(base, this.M._ms_wasm_live_set_base);
  }

  control(bytes) {
    const p = this.copyIn(bytes, 1);
    const rc = this.M._ms_wasm_live_control(this.s, p, bytes.byteLength);
    this.M._free(p);
    this.check(rc === 0, 'control block');
  }

  datagram(bytes) {
    const p = this.copyIn(bytes, 1);
    this.M._ms_wasm_live_datagram(this.s, p, bytes.byteLength);
    this.M._free(p);
  }

  end(refinement, datagrams) {
    this.M._ms_wasm_live_end(this.s, refinement, datagrams);
  }

  // Whatever of `refinement` has not arrived will not.
  declare(refinement) {
    this.M._ms_wasm_live_declare(this.s, refinement);
  }

  // Decodes what is ready; the refinements applied so far.
  poll() {
    const n = this.M._ms_wasm_live_poll(this.s);
    this.check(n >= 0, 'decode');
    return n;
  }

  flush() {
    const n = this.M._ms_wasm_live_flush(this.s);
    this.check(n >= 0, 'decode');
    return n;
  }

  // The current mesh for arrays() and hash().
  snapshot() {
    this.check(this.M._ms_wasm_live_snapshot(this.s) === 0, 'snapshot');
  }
}
