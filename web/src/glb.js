// A progressive .glb read the way the browser side needs it: the JSON, the
// binary chunk, and per refined primitive (in stream order: meshes in order,
// each mesh's primitives in file order) its Draco base bytes and attribute
// ids, its stream blob and its delivery record (docs/progressive-format.md).
// Throws an Error naming what is wrong; never reads outside the buffer.

const GLB_MAGIC = 0x46546c67;
const CHUNK_JSON = 0x4e4f534a;
const CHUNK_BIN = 0x004e4942;

export function parseGlb(bytes) {
  if (!(bytes instanceof Uint8Array)) throw new TypeError('parseGlb: expected a Uint8Array');
  if (bytes.byteLength < 20) throw new Error('not a .glb: ' + bytes.byteLength + ' bytes');
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (dv.getUint32(0, true) !== GLB_MAGIC) throw new Error('not a .glb: bad magic');
  if (dv.getUint32(4, true) !== 2) throw new Error('glb version ' + dv.getUint32(4, true) + ' is not 2');
  const length = Math.min(dv.getUint32(8, true), bytes.byteLength);
  let json = null;
  let bin = null;
  for (let off = 12; off + 8 <= length; ) {
    const size = dv.getUint32(off, true);
    const type = dv.getUint32(off + 4, true);
    if (size > length - off - 8) throw new Error('glb chunk at byte ' + off + ' runs past the end');
    const chunk = bytes.subarray(off + 8, off + 8 + size);
    if (type === CHUNK_JSON && json === null) json = JSON.parse(new TextDecoder().decode(chunk));
    else if (type === CHUNK_BIN && bin === null) bin = chunk;
    off += 8 + size;
  }
  if (json === null) throw new Error('glb has no JSON chunk');
  return { json, bin };
}

export function bufferView(glb, index) {
  const views = glb.json.bufferViews || [];
  const v = views[index];
  if (!v) throw new Error('bufferView ' + index + ' does not exist');
  const offset = v.byteOffset || 0;
  if (!glb.bin || offset + v.byteLength > glb.bin.byteLength) {
    throw new Error('bufferView ' + index + ' lies outside the binary chunk');
  }
  return glb.bin.subarray(offset, offset + v.byteLength);
}

// Draco attribute ids in the order the native importer reads them.
function dracoIds(draco) {
  const a = draco.attributes || {};
  const texcoords = [];
  for (let k = 0; ('TEXCOORD_' + k) in a; ++k) texcoords.push(a['TEXCOORD_' + k]);
  return {
    position: a.POSITION,
    normal: 'NORMAL' in a ? a.NORMAL : -1,
    texcoords,
    color: 'COLOR_0' in a ? a.COLOR_0 : -1,
  };
}

export function progressivePrimitives(glb) {
  const out = [];
  const meshes = glb.json.meshes || [];
  meshes.forEach((mesh, m) => {
    (mesh.primitives || []).forEach((prim, j) => {
      const ext = prim.extensions || {};
      const progressive = ext.MESHSTREAM_progressive;
      const draco = ext.KHR_draco_mesh_compression;
      if (!progressive || !draco) return;
      out.push({
        where: 'meshes[' + m + '].primitives[' + j + ']',
        streamId: out.length,
        blob: bufferView(glb, progressive.bufferView),
        base: bufferView(glb, draco.bufferView),
        ids: dracoIds(draco),
        reliable: (progressive.delivery && progressive.delivery.reliable) || [],
      });
    });
  });
  return out;
}
