// One primitive's progressive stream decoded by the wasm module
// (web/wasm/decoder_api.h): the blob, the base as draco3d decoded it, then
// the decode; the result as typed arrays copied out of the module's memory.
// Every failure throws an Error with the decoder's message.

export class StreamDecoder {
  constructor(M, blob, streamId) {
    this.M = M;
    const p = this.copyIn(blob, 1);
    this.s = M._ms_wasm_open(p, blob.byteLength, streamId);
    M._free(p);
    if (this.s === 0) throw new Error('out of memory');
    this.check(this.error() === '', 'open');
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

  setBase(base) {
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
    const rc = this.M._ms_wasm_set_base(this.s, base.vertices, ptrs[0], ptrs[1], sets, ptrs[2], ptrs[3],
                                        base.indices.length, ptrs[4]);
    for (const p of ptrs) if (p) this.M._free(p);
    this.check(rc === 0, 'base');
  }

  decode({ lod = -1, loss = 0, burst = 0, seed = 1, reliable = [] } = {}) {
    const r = this.copyIn(Uint32Array.from(reliable), 4);
    const rc = this.M._ms_wasm_decode(this.s, lod, loss, burst, seed, r, reliable.length);
    this.M._free(r);
    this.check(rc === 0, 'decode');
  }

  hash() {
    return this.M.UTF8ToString(this.M._ms_wasm_hash(this.s));
  }

  arrays() {
    const M = this.M, s = this.s;
    const n = M._ms_wasm_vertex_count(s), ni = M._ms_wasm_index_count(s);
    const floats = (p, k) => (p ? new Float32Array(M.HEAPU8.buffer, p, k * n).slice() : null);
    const texcoords = [];
    for (let t = 0; t < M._ms_wasm_texcoord_sets(s); ++t) texcoords.push(floats(M._ms_wasm_texcoords(s, t), 2));
    const ip = M._ms_wasm_indices(s);
    return {
      vertices: n,
      positions: floats(M._ms_wasm_positions(s), 3),
      normals: floats(M._ms_wasm_normals(s), 3),
      texcoords,
      colors: floats(M._ms_wasm_colors(s), 4),
      indices: ip ? new Uint32Array(M.HEAPU8.buffer, ip, ni).slice() : new Uint32Array(0),
      predictedVertices: M._ms_wasm_predicted_vertices(s),
    };
  }

  close() {
    if (this.s) this.M._ms_wasm_close(this.s);
    this.s = 0;
  }
}
