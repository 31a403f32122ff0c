// A progressive .glb read the way the browser side needs it: the JSON, the
// binary chunk, and per refined primitive (in stream order: meshes in order,
// each mesh's primitives in file order) its Draco base bytes and attribute
// ids, its stream blob (or only where it lies in the file, for a prefix) and
// its delivery record (docs/spec/progressive-format.md).
// Throws an Error naming what is wrong; never reads outside the buffer.

const GLB_MAGIC = 0x46546c67;

// The JSON's arrays and objects checked before use: the file is untrusted.
const isObject = (v) => v !== null && typeof v === 'object' && !Array.isArray(v);
function arrayOf(v, what) {
  if (v === undefined) return [];
  if (!Array.isArray(v)) throw new Error('glb: ' + what + ' is not an array');
  return v;
}
function objectAt(list, i, what) {
  if (!isObject(list[i])) throw new Error('glb: ' + what + '[' + i + '] is not an object');
  return list[i];
}
const isCount = (v) => Number.isSafeInteger(v) && v >= 0;
const CHUNK_JSON = 0x4e4f534a;
const CHUNK_BIN = 0x004e4942;

// `truncated`: the bytes are a prefix of the file (an HTTP range read up to
// the first stream blob): the binary chunk may end early, and a bufferView
// past its end is left out of progressivePrimitives' bytes.
export function parseGlb(bytes, { truncated = false } = {}) {
  if (!(bytes instanceof Uint8Array)) throw new TypeError('parseGlb: expected a Uint8Array');
  if (bytes.byteLength < 20) throw new Error('not a .glb: ' + bytes.byteLength + ' bytes');
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (dv.getUint32(0, true) !== GLB_MAGIC) throw new Error('not a .glb: bad magic');
  if (dv.getUint32(4, true) !== 2) throw new Error('glb version ' + dv.getUint32(4, true) + ' is not 2');
  const length = Math.min(dv.getUint32(8, true), bytes.byteLength);
  let json = null;
  let bin = null;
  let binOffset = -1;  // the file offset of the binary chunk's data
  for (let off = 12; off + 8 <= length; ) {
    const size = dv.getUint32(off, true);
    const type = dv.getUint32(off + 4, true);
    const isBin = type === CHUNK_BIN && bin === null;
    if (size > length - off - 8 && !(truncated && isBin)) {
      throw new Error('glb chunk at byte ' + off + ' runs past the end');
    }
    const chunk = bytes.subarray(off + 8, Math.min(off + 8 + size, length));
    if (type === CHUNK_JSON && json === null) {
      json = JSON.parse(new TextDecoder().decode(chunk));
    } else if (isBin) {
      bin = chunk;
      binOffset = off + 8;
    }
    off += 8 + size;
  }
  if (json === null) throw new Error('glb has no JSON chunk');
  return { json, bin, binOffset };
}

// The file's first bytes needed to know its layout: the 12-byte header and
// the JSON chunk; null when `bytes` does not hold them yet, else how many
// bytes the header and JSON take (the binary chunk's header follows).
export function glbJsonEnd(bytes) {
  if (bytes.byteLength < 20) return null;
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  if (dv.getUint32(0, true) !== GLB_MAGIC) throw new Error('not a .glb: bad magic');
  if (dv.getUint32(16, true) !== CHUNK_JSON) throw new Error('glb: the first chunk is not JSON');
  const end = 20 + dv.getUint32(12, true);
  if (end > 1 << 28) throw new Error('glb: a JSON chunk of ' + (end - 20) + ' bytes');
  return end;
}

// The file offset where the first stream blob starts (the scene at its base
// level lies before it), or the file's length when it has none.
export function firstBlobOffset(json, binOffset, fileLength) {
  let first = fileLength;
  const meshes = arrayOf(json.meshes, 'meshes');
  meshes.forEach((_, m) => {
    const prims = arrayOf(objectAt(meshes, m, 'meshes').primitives, `meshes[${m}].primitives`);
    prims.forEach((_, j) => {
      const prim = objectAt(prims, j, `meshes[${m}].primitives`);
      const ext = isObject(prim.extensions) ? prim.extensions.MESHSTREAM_progressive : undefined;
      if (!isObject(ext)) return;
      for (const index of [ext.bufferView, ext.reliable]) {
        if (index === undefined) continue;
        const v = arrayOf(json.bufferViews, 'bufferViews')[index];
        if (isObject(v) && isCount(v.byteOffset || 0)) first = Math.min(first, binOffset + (v.byteOffset || 0));
      }
    });
  });
  return first;
}

// A bufferView's bytes; null when `optional` and the bytes are not (yet)
// there (a truncated file).
export function bufferView(glb, index, optional = false) {
  const views = arrayOf(glb.json.bufferViews, 'bufferViews');
  const v = Number.isSafeInteger(index) && index >= 0 ? views[index] : undefined;
  if (!isObject(v)) throw new Error('bufferView ' + index + ' does not exist');
  const offset = v.byteOffset === undefined ? 0 : v.byteOffset;
  if (!isCount(offset) || !isCount(v.byteLength)) {
    throw new Error('bufferView ' + index + ': byteOffset and byteLength must be counts');
  }
  if (!glb.bin || offset + v.byteLength > glb.bin.byteLength) {
    if (optional) return null;
    throw new Error('bufferView ' + index + ' lies outside the binary chunk');
  }
  return glb.bin.subarray(offset, offset + v.byteLength);
}

// A bufferView's place in the file: { start, end } (end exclusive).
function fileRange(glb, index) {
  const v = Number.isSafeInteger(index) && index >= 0 ? arrayOf(glb.json.bufferViews, 'bufferViews')[index] : undefined;
  if (!isObject(v)) throw new Error('bufferView ' + index + ' does not exist');
  const offset = v.byteOffset === undefined ? 0 : v.byteOffset;
  if (!isCount(offset) || !isCount(v.byteLength)) {
    throw new Error('bufferView ' + index + ': byteOffset and byteLength must be counts');
  }
  const start = glb.binOffset + offset;
  return { start, end: start + v.byteLength };
}

// Draco attribute ids in the order the native importer reads them.
function dracoIds(draco) {
  const a = draco.attributes === undefined ? {} : draco.attributes;
  if (!isObject(a)) throw new Error('KHR_draco_mesh_compression.attributes is not an object');
  const texcoords = [];
  for (let k = 0; ('TEXCOORD_' + k) in a; ++k) texcoords.push(a['TEXCOORD_' + k]);
  return {
    position: a.POSITION,
    normal: 'NORMAL' in a ? a.NORMAL : -1,
    texcoords,
    color: 'COLOR_0' in a ? a.COLOR_0 : -1,
  };
}

// `profile`: 'auto' (the reliable profile's stream where the file has both),
// 'reliable' or 'loss-tolerant' (the other stream where it has one).
export function progressivePrimitives(glb, profile = 'auto') {
  const out = [];
  const meshes = arrayOf(glb.json.meshes, 'meshes');
  meshes.forEach((_, m) => {
    const prims = arrayOf(objectAt(meshes, m, 'meshes').primitives, `meshes[${m}].primitives`);
    prims.forEach((_, j) => {
      const prim = objectAt(prims, j, `meshes[${m}].primitives`);
      const ext = isObject(prim.extensions) ? prim.extensions : {};
      const progressive = ext.MESHSTREAM_progressive;
      const draco = ext.KHR_draco_mesh_compression;
      if (!isObject(progressive) || !isObject(draco)) return;
      // A file with both profiles (format version 4, what the server
      // stores): the reliable profile's stream, which a file or HTTP ranges
      // carry whole (smaller, faster to decode; docs/design/web.md). Its blobs lie
      // together before the loss-tolerant ones, so one ranged GET reads them.
      const both = progressive.reliable !== undefined;
      const view = both && profile !== 'loss-tolerant' ? progressive.reliable : progressive.bufferView;
      out.push({
        where: 'meshes[' + m + '].primitives[' + j + ']',
        mesh: m,
        primitive: j,
        streamId: out.length,
        blob: bufferView(glb, view, true),  // null in a truncated file
        blobRange: fileRange(glb, view),
        base: bufferView(glb, draco.bufferView),
        ids: dracoIds(draco),
        // The loss-tolerant profile's reliable cut (none in the reliable profile).
        reliable: view === progressive.bufferView && isObject(progressive.delivery) &&
          Array.isArray(progressive.delivery.reliable)
          ? progressive.delivery.reliable.filter(isCount) : [],
      });
    });
  });
  return out;
}
