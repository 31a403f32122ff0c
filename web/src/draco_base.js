// The base mesh of a progressive primitive as Draco decodes it, with
// draco3d (the same Draco release as the native decoder's libdraco): floats
// per point in the order the native importer reads them (importers/
// draco_codec.cc, ReadAttribute: missing components 0, a colour without
// alpha opaque), and the triangles.

export function decodeDracoBase(D, bytes, ids) {
  const decoder = new D.Decoder();
  const mesh = new D.Mesh();
  try {
    const status = decoder.DecodeArrayToMesh(bytes, bytes.byteLength, mesh);
    if (!status.ok()) throw new Error('Draco decoding failed: ' + status.error_msg());
    const n = mesh.num_points();
    const floats = (id, comps, name) => {
      const att = decoder.GetAttributeByUniqueId(mesh, id);
      if (!att || att.ptr === 0) throw new Error('Draco stream has no attribute with id ' + id + ' for ' + name);
      const nc = att.num_components();
      if (nc < 1 || nc > comps) throw new Error(name + ' has ' + nc + ' components, expected ' + comps);
      const arr = new D.DracoFloat32Array();
      try {
        if (!decoder.GetAttributeFloatForAllPoints(mesh, att, arr)) throw new Error(name + ': cannot read as floats');
        const out = new Float32Array(n * comps);
        for (let i = 0; i < n; ++i) {
          for (let c = 0; c < comps; ++c) {
            out[i * comps + c] = c < nc ? arr.GetValue(i * nc + c) : comps === 4 && c === 3 ? 1 : 0;
          }
        }
        return out;
      } finally {
        D.destroy(arr);
      }
    };
    const base = {
      vertices: n,
      positions: floats(ids.position, 3, 'POSITION'),
      normals: ids.normal >= 0 ? floats(ids.normal, 3, 'NORMAL') : null,
      texcoords: ids.texcoords.map((id, k) => floats(id, 2, 'TEXCOORD_' + k)),
      colors: ids.color >= 0 ? floats(ids.color, 4, 'COLOR_0') : null,
    };
    // The triangles in one call into the module's heap, copied out.
    const indexBytes = mesh.num_faces() * 3 * 4;
    const p = D._malloc(Math.max(indexBytes, 4));
    try {
      if (!decoder.GetTrianglesUInt32Array(mesh, indexBytes, p)) throw new Error('Draco: cannot read the triangles');
      base.indices = new Uint32Array(D.HEAPU32.buffer, p, indexBytes / 4).slice();
    } finally {
      D._free(p);
    }
    return base;
  } finally {
    D.destroy(mesh);
    D.destroy(decoder);
  }
}
