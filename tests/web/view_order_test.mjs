// web/src/view_order.js, the HTTP-range path's order by view, under node:
// the streams in the camera's frustum come first, nearer and coarser before
// farther and finer, outside ones last; node transforms move the boxes; and
// the pixels agree with the server's rule (codec/progressive/view_order.h:
// error x (height / 2) x focal / depth for a perspective camera).
import { outsideFrustum, screenError, streamBoxes, viewOrder } from '../../web/src/view_order.js';

let failures = 0;
const expect = (ok, what) => {
  if (!ok) {
    console.error('view_order_test: ' + what);
    ++failures;
  }
};

// A perspective camera at `eye` looking down -z (fov 60 degrees, 1000 x 800).
function camera(eye) {
  const t = 1 / Math.tan(Math.PI / 6), aspect = 1000 / 800, near = 0.1, far = 100;
  const a = (far + near) / (near - far), b = (2 * far * near) / (near - far);
  // view = translation by -eye; projection columns as glTF's perspective.
  const vp = [t / aspect, 0, 0, 0, 0, t, 0, 0, 0, 0, a, -1,
              -t / aspect * eye[0], -t * eye[1], -a * eye[2] + b, eye[2]];
  return { camera: eye, viewProjection: vp, width: 1000, height: 800 };
}

// Four parts of one mesh along x (boxes [2p - 1, 2p + 1] x [-1, 1]^2), the same errors.
function file(nodes) {
  const accessors = [], primitives = [];
  for (let p = 0; p < 4; ++p) {
    accessors.push({ min: [2 * p - 1, -1, -1], max: [2 * p + 1, 1, 1] });
    primitives.push({ attributes: { POSITION: p }, extensions: { MESHSTREAM_progressive: { residual_error: [0.01, 0.001, 0] } } });
  }
  const json = { accessors, meshes: [{ primitives }] };
  if (nodes) Object.assign(json, nodes);
  const prims = primitives.map((_, j) => ({ mesh: 0, primitive: j, streamId: j }));
  return { json, prims };
}

{
  const { json, prims } = file(null);
  // The camera in front of part 0, close: parts 2 and 3 outside the frustum.
  const view = camera([0, 0, 3]);
  const order = viewOrder(json, prims, view);
  const pair = (o, a, b) => (o[0] === a && o[1] === b) || (o[0] === b && o[1] === a);
  expect(pair(order, 0, 1), 'the parts in the frustum first: ' + order);
  const boxes = streamBoxes(json, prims);
  expect(!outsideFrustum(view, boxes[0]) && outsideFrustum(view, boxes[3]), 'the frustum test');
  // One unit at depth 2 (the box's face at z = 1): 400 x focal / 2 pixels.
  const want = (400 / Math.tan(Math.PI / 6)) / 2;
  expect(Math.abs(screenError(view, boxes[0], 1) - want) < 1e-6 * want, `pixels ${screenError(view, boxes[0], 1)} != ${want}`);
  // The camera moved to part 3: the order turns around.
  const back = viewOrder(json, prims, camera([6, 0, 3]));
  expect(pair(back, 2, 3), 'the far side first from there: ' + back);
  // Part 1 pushed back in depth (z in [-9, -7]): the nearer part 0 comes before it.
  json.accessors[1].min[2] = -9;
  json.accessors[1].max[2] = -7;
  const deep = viewOrder(json, prims, camera([0.5, 0, 3]));
  expect(deep[0] === 0 && deep.indexOf(1) > deep.indexOf(2), 'nearer first (part 2 is seen at depth 2 too): ' + deep);
}
{
  // A node moves the mesh by -6 in x: part 3 now sits in front of the camera at x = 0.
  const { json, prims } = file({ scenes: [{ nodes: [0] }], nodes: [{ mesh: 0, translation: [-6, 0, 0] }] });
  const order = viewOrder(json, prims, camera([0, 0, 3]));
  expect((order[0] === 3 || order[0] === 2) && (order[1] === 3 || order[1] === 2), 'the node transform moves the boxes: ' + order);
}
{
  // A stream without residual errors goes last, the rest keep the rule.
  const { json, prims } = file(null);
  delete json.meshes[0].primitives[0].extensions.MESHSTREAM_progressive.residual_error;
  const order = viewOrder(json, prims, camera([0, 0, 3]));
  expect(order[order.length - 1] === 0 && order[0] === 1, 'unknown errors last: ' + order);
}
if (failures > 0) process.exit(1);
console.log('view_order_test: passed');
