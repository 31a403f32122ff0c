// Which streams a view needs first, for the HTTP-range path
// (docs/spec/streaming-protocol.md, "Views"): the rule of the server's
// codec/progressive/view_order.h, in the browser. A stream's box is its
// base's POSITION min/max through the world matrix of every node of the
// default scene that shows its mesh; its importance is the error before its
// first refinement (MESHSTREAM_progressive.residual_error[0], scene units)
// in pixels at the box's point nearest the camera (error x s / w: w that
// point's clip w, at least 1e-5 of the box's diagonal; s the larger of
// |row 0| x width / 2 and |row 1| x height / 2); a box wholly outside one
// plane of the frustum counts 1e-9 of its scene error.
//
// view: { camera: [x, y, z], viewProjection: 16 numbers column-major, width, height }.

function multiply(a, b) {
  const out = new Array(16).fill(0);
  for (let c = 0; c < 4; ++c) for (let r = 0; r < 4; ++r) for (let k = 0; k < 4; ++k) out[c * 4 + r] += a[k * 4 + r] * b[c * 4 + k];
  return out;
}

function localMatrix(node) {
  if (Array.isArray(node.matrix) && node.matrix.length === 16) return node.matrix.map(Number);
  const [tx, ty, tz] = Array.isArray(node.translation) ? node.translation : [0, 0, 0];
  const [x, y, z, w] = Array.isArray(node.rotation) ? node.rotation : [0, 0, 0, 1];
  const [sx, sy, sz] = Array.isArray(node.scale) ? node.scale : [1, 1, 1];
  return [
    (1 - 2 * (y * y + z * z)) * sx, (2 * (x * y + z * w)) * sx, (2 * (x * z - y * w)) * sx, 0,
    (2 * (x * y - z * w)) * sy, (1 - 2 * (x * x + z * z)) * sy, (2 * (y * z + x * w)) * sy, 0,
    (2 * (x * z + y * w)) * sz, (2 * (y * z - x * w)) * sz, (1 - 2 * (x * x + y * y)) * sz, 0,
    tx, ty, tz, 1];
}

const row = (m, r, p) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r];
const rowScale = (m, r) => Math.hypot(m[r], m[4 + r], m[8 + r]);

function corners(box) {
  const out = [];
  for (let i = 0; i < 8; ++i) out.push([i & 1 ? box.hi[0] : box.lo[0], i & 2 ? box.hi[1] : box.lo[1], i & 4 ? box.hi[2] : box.lo[2]]);
  return out;
}

// Per mesh, the world matrices of the nodes that show it.
function meshInstances(json) {
  const meshes = Array.isArray(json.meshes) ? json.meshes.length : 0;
  const out = Array.from({ length: meshes }, () => []);
  const identity = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
  const scenes = Array.isArray(json.scenes) ? json.scenes : [];
  const nodes = Array.isArray(json.nodes) ? json.nodes : [];
  if (scenes.length === 0 || nodes.length === 0) {
    out.forEach((m) => m.push(identity));
    return out;
  }
  const scene = scenes[Number.isInteger(json.scene) && json.scene < scenes.length ? json.scene : 0] || {};
  const stack = (Array.isArray(scene.nodes) ? scene.nodes : []).map((n) => [n, identity]);
  const seen = new Set();
  while (stack.length > 0) {
    const [index, parent] = stack.pop();
    if (!Number.isInteger(index) || index < 0 || index >= nodes.length || seen.has(index)) continue;
    seen.add(index);
    const node = nodes[index] || {};
    const world = multiply(parent, localMatrix(node));
    if (Number.isInteger(node.mesh) && node.mesh >= 0 && node.mesh < meshes) out[node.mesh].push(world);
    for (const c of Array.isArray(node.children) ? node.children : []) stack.push([c, world]);
  }
  return out;
}

// Per progressive primitive (glb.js's progressivePrimitives), its box in the
// scene, or null.
export function streamBoxes(json, prims) {
  const instances = meshInstances(json);
  return prims.map((p) => {
    const prim = json.meshes[p.mesh].primitives[p.primitive];
    const accessor = (json.accessors || [])[prim.attributes && prim.attributes.POSITION];
    if (!accessor || !Array.isArray(accessor.min) || !Array.isArray(accessor.max) || instances[p.mesh].length === 0) return null;
    const local = { lo: accessor.min.map(Number), hi: accessor.max.map(Number) };
    let box = null;
    for (const m of instances[p.mesh]) {
      for (const c of corners(local)) {
        const q = [row(m, 0, c), row(m, 1, c), row(m, 2, c)];
        if (!box) box = { lo: q.slice(), hi: q.slice() };
        for (let a = 0; a < 3; ++a) {
          box.lo[a] = Math.min(box.lo[a], q[a]);
          box.hi[a] = Math.max(box.hi[a], q[a]);
        }
      }
    }
    return box;
  });
}

export function outsideFrustum(view, box) {
  const m = view.viewProjection;
  const clip = corners(box).map((c) => [row(m, 0, c), row(m, 1, c), row(m, 2, c), row(m, 3, c)]);
  for (let axis = 0; axis < 3; ++axis) {
    for (const side of [-1, 1]) if (clip.every((k) => side * k[axis] > k[3])) return true;
  }
  return false;
}

export function screenError(view, box, error) {
  if (!(error > 0)) return 0;
  const m = view.viewProjection;
  const nearest = [0, 1, 2].map((a) => Math.min(Math.max(view.camera[a], box.lo[a]), box.hi[a]));
  const diagonal = Math.hypot(box.hi[0] - box.lo[0], box.hi[1] - box.lo[1], box.hi[2] - box.lo[2]);
  const w = Math.max(row(m, 3, nearest), Math.max(diagonal, 1e-30) * 1e-5);
  const scale = Math.max(rowScale(m, 0) * view.width, rowScale(m, 1) * view.height) / 2;
  const pixels = (error * scale) / w;
  return Number.isFinite(pixels) ? pixels : 0;
}

// The streams' ids, the ones the view needs first: by the pixels of their
// first refinement's error, larger first (ties: the lower stream); streams
// without a box or residual errors last, in their order.
export function viewOrder(json, prims, view) {
  const boxes = streamBoxes(json, prims);
  const keyed = prims.map((p, i) => {
    const ext = json.meshes[p.mesh].primitives[p.primitive].extensions.MESHSTREAM_progressive;
    const errors = Array.isArray(ext.residual_error) ? ext.residual_error : null;
    const box = boxes[i];
    if (!box || !errors || errors.length === 0) return { id: p.streamId, known: false, key: 0 };
    const e = Number(errors[0]);
    return { id: p.streamId, known: true, key: outsideFrustum(view, box) ? e * 1e-9 : screenError(view, box, e) };
  });
  keyed.sort((a, b) => (a.known !== b.known ? (a.known ? -1 : 1) : b.key !== a.key ? b.key - a.key : a.id - b.id));
  return keyed.map((k) => k.id);
}
