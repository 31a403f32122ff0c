// A page of a web developer who installed @meshstream/web from npm
// (tests/web/npm_package_run.sh bundles it with esbuild): three.js with
// GLTFLoader and DRACOLoader, the package's plugin as its README shows it,
// the worker's files where `meshstream-web-assets` copied them
// (meshstream/), three's Draco decoder in draco/.
// ?url=the progressive .glb. window.meshstreamTest, for the test:
//   status  'loading', 'base', 'complete' or 'error' (and error: the message)
//   base    { vertices, referenced, faces, drawn } at the base: the scene's counts
//           (counts()) and the share of the canvas that is not the background once drawn
//   levels  [{ streamId, level, levels, vertices, faces }] as the plugin posted them
//   final   the same after 'complete'
import { Box3, Color, DirectionalLight, HemisphereLight, PerspectiveCamera, Scene, Vector3, WebGLRenderer } from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { MeshstreamProgressive } from '@meshstream/web';

const state = { status: 'loading', error: null, base: null, levels: [], final: null };
window.meshstreamTest = state;

const canvas = document.getElementById('view');
const renderer = new WebGLRenderer({ canvas, preserveDrawingBuffer: true });
const scene = new Scene();
scene.background = new Color(0x000000);
scene.add(new HemisphereLight(0xffffff, 0x404850, 1.6));
const sun = new DirectionalLight(0xffffff, 1.8);
sun.position.set(1, 2, 3);
scene.add(sun);
const camera = new PerspectiveCamera(45, canvas.width / canvas.height, 0.001, 1000);

// What the scene's meshes hold and draw: vertices (their position
// attributes), referenced (those the drawn triangles use) and faces.
function counts(root) {
  let vertices = 0, referenced = 0, faces = 0;
  root.traverse((o) => {
    if (!o.isMesh) return;
    const g = o.geometry;
    const n = g.getAttribute('position').count;
    const drawn = g.index ? Math.min(g.index.count, g.drawRange.count) : n;
    let used = n;
    if (g.index) {
      used = 0;
      for (let i = 0; i < drawn; ++i) used = Math.max(used, g.index.array[i] + 1);
    }
    vertices += n;
    referenced += used;
    faces += drawn / 3;
  });
  return { vertices, referenced, faces };
}

// The share of the canvas's pixels that are not the (black) background.
function drawnShare() {
  renderer.render(scene, camera);
  const gl = renderer.getContext();
  const px = new Uint8Array(canvas.width * canvas.height * 4);
  gl.readPixels(0, 0, canvas.width, canvas.height, gl.RGBA, gl.UNSIGNED_BYTE, px);
  let other = 0;
  for (let i = 0; i < px.length; i += 4) if (px[i] + px[i + 1] + px[i + 2] > 24) ++other;
  return other / (canvas.width * canvas.height);
}

async function main() {
  const url = new URLSearchParams(location.search).get('url');
  const progressive = new MeshstreamProgressive({ workerUrl: new URL('meshstream/src/worker.js', location.href) });
  const loader = new GLTFLoader().setDRACOLoader(new DRACOLoader().setDecoderPath('draco/'));
  loader.register((parser) => progressive.plugin(parser));
  progressive.addEventListener('level', (e) => {
    state.levels.push({ streamId: e.streamId, level: e.level, levels: e.levels, vertices: e.vertices, faces: e.faces });
  });
  progressive.addEventListener('error', (e) => {
    state.error = e.error.message;
    state.status = 'error';
  });
  const gltf = await progressive.load(loader, url);
  scene.add(gltf.scene);
  const box = new Box3().setFromObject(gltf.scene);
  const center = box.getCenter(new Vector3()), size = box.getSize(new Vector3()).length();
  camera.position.copy(center).add(new Vector3(0, 0, size * 1.2));
  camera.near = size / 100;
  camera.far = size * 10;
  camera.updateProjectionMatrix();
  camera.lookAt(center);
  state.base = Object.assign(counts(gltf.scene), { drawn: drawnShare() });
  if (state.status === 'loading') state.status = 'base';
  await progressive.complete;
  state.final = Object.assign(counts(gltf.scene), { drawn: drawnShare() });
  state.status = 'complete';
}

main().catch((e) => {
  state.error = String(e && e.stack ? e.stack : e);
  state.status = 'error';
});
