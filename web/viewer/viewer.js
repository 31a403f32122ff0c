// The viewer at `meshstream serve --http-listen`'s root (docs/design/web.md): lists
// the assets, loads one with GLTFLoader and the meshstream plugin, from the
// file by HTTP ranges or from a live session over WebSocket, and shows the
// level, bytes, time to base and to full quality, with predicted vertices
// tinted. Query parameters preset the form and `auto=1` loads at once (the
// browser tests and `make demo` drive the page that way):
//   ?asset=NAME&version=N|latest&mode=ranges|live|draco&lod=K&loss=0.1&tint=0|1&auto=1
// Mode `draco` loads the Draco .glb export with three.js's own GLTFLoader and
// DRACOLoader (no meshstream code): the reference `make bench-web` measures.
// window.meshstreamViewer holds the state a test reads: ready (the decoders
// are loaded), status ('idle', 'loading', 'base', 'complete', 'error'), per
// stream its levels and final hash, the timings (ms from the click: base and
// full when the events came, baseDrawn and fullDrawn when the next frame
// showed them) and the bytes.

import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { MeshstreamProgressive, viewOfCamera } from './src/plugin.js';
import { DecoderWorker } from './src/client.js';

const $ = (id) => document.getElementById(id);
const params = new URLSearchParams(location.search);
const state = { ready: false, status: 'idle', streams: {}, timings: {}, bytes: 0, error: null, frames: 0 };
window.meshstreamViewer = state;

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio || 1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202428);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404850, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(1, 2, 3);
scene.add(sun);
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 1000);
camera.position.set(0, 0, 3);
const controls = new OrbitControls(camera, canvas);
let dirty = true;
let started = 0;
const drawnMarks = new Set();  // 'baseDrawn', 'fullDrawn': stamped by the next frame
controls.addEventListener('change', () => { dirty = true; });

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio())) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
    dirty = true;
  }
}
function frame() {
  resize();
  // A live session orders what it sends by what this camera sees (throttled in the plugin).
  if (current && current.progressive.setView) current.progressive.setView(camera, canvas.width, canvas.height);
  if (dirty) {
    renderer.render(scene, camera);
    state.frames += 1;
    dirty = false;
    for (const mark of drawnMarks) state.timings[mark] = performance.now() - started;
    drawnMarks.clear();
  }
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);

const dracoLoader = new DRACOLoader().setDecoderPath(new URL('./vendor/three/examples/jsm/libs/draco/gltf/', location.href).href);
const worker = new DecoderWorker();  // shared by every load
// Both decoders loaded before any timing starts (DRACOLoader's for the base
// and the Draco page, the worker's wasm for the refinements).
dracoLoader.preload();
const decodersReady = Promise.all([worker.ready, dracoLoader.decoderPending]).then(() => { state.ready = true; });
decodersReady.catch((e) => fail(new Error('loading the decoders: ' + e.message)));
let current = null;  // { progressive, root }

function frameObject(root) {
  const box = new THREE.Box3().setFromObject(root);
  if (box.isEmpty()) return;
  const size = box.getSize(new THREE.Vector3()).length();
  const center = box.getCenter(new THREE.Vector3());
  controls.target.copy(center);
  camera.near = size / 100;
  camera.far = size * 100;
  // The bounding sphere fits the narrower of the two fields of view.
  const half = THREE.MathUtils.degToRad(camera.fov / 2);
  const fit = Math.min(Math.tan(half), Math.tan(half) * camera.aspect);
  const distance = (0.5 * size) / fit;
  camera.position.copy(center).add(new THREE.Vector3(0.35, 0.25, 1).normalize().multiplyScalar(distance));
  camera.updateProjectionMatrix();
  controls.update();
  dirty = true;
}

function show(id, text) {
  $(id).textContent = text;
}

function headers() {
  const token = $('token').value.trim();
  return token ? { Authorization: 'Bearer ' + token } : {};
}

async function listAssets() {
  const select = $('asset');
  try {
    const response = await fetch('v1/assets', { headers: headers() });
    if (!response.ok) throw new Error('HTTP ' + response.status);
    const body = await response.json();
    select.replaceChildren();
    for (const a of body.assets || []) {
      const option = document.createElement('option');
      option.value = a.asset;
      option.textContent = a.asset + (a.latest_version ? ' (v' + a.latest_version + ')' : '');
      select.append(option);
    }
  } catch (e) {
    $('error').textContent = 'listing the assets: ' + e.message;
  }
  if (params.get('asset')) {
    if (![...select.options].some((o) => o.value === params.get('asset'))) {
      const option = document.createElement('option');
      option.value = option.textContent = params.get('asset');
      select.append(option);
    }
    select.value = params.get('asset');
  }
}

async function load() {
  if (current) {
    current.progressive.dispose({ geometries: true });
    scene.remove(current.root);
    current = null;
  }
  const asset = $('asset').value;
  const version = $('version').value.trim() || 'latest';
  const live = $('mode').value === 'live';
  if ($('mode').value === 'draco') return loadDraco();
  const lod = Number($('lod').value);
  const loss = live ? 0 : Number($('loss').value) || 0;
  begin();
  const url = new URL(`v1/assets/${encodeURIComponent(asset)}/versions/${version}/progressive`, location.href).href;
  // ?workers=N: a file's streams (primitives, spatial parts) decoded by N Web Workers.
  const workers = Math.max(1, Math.min(16, Number(params.get('workers')) || 1));
  const options = { headers: headers(), lod, loss, seed: 1, tintPredicted: $('tint').checked, worker, workers };
  if (live) {
    const ws = new URL('v1/stream', location.href);
    ws.protocol = location.protocol === 'https:' ? 'wss:' : 'ws:';
    options.session = { url: ws.href, asset, version: version === 'latest' ? 0 : Number(version), lod,
                        token: $('token').value.trim() };
  } else {
    // By ranges: the camera framed on the base decides which streams come first.
    options.view = (result) => {
      frameObject(result.scene || result.scenes[0]);
      return viewOfCamera(camera, canvas.width, canvas.height);
    };
  }
  const progressive = new MeshstreamProgressive(options);
  const loader = new GLTFLoader().setDRACOLoader(dracoLoader);
  loader.register((parser) => progressive.plugin(parser));
  let totalVertices = {};
  progressive.addEventListener('level', (e) => {
    const s = state.streams[e.streamId] || (state.streams[e.streamId] = { levels: [], hash: null });
    s.levels.push({ level: e.level, vertices: e.vertices, faces: e.faces });
    s.hash = e.hash;
    s.predicted = e.predictedVertices;
    totalVertices[e.streamId] = e.vertices;
    state.bytes = progressive.stats.bytes;
    show('s-level', `${e.level} / ${e.levels}` + (Object.keys(state.streams).length > 1 ? ` (stream ${e.streamId})` : ''));
    show('s-vertices', Object.values(totalVertices).reduce((a, b) => a + b, 0).toLocaleString());
    show('s-predicted', Object.values(state.streams).reduce((a, s) => a + (s.predicted || 0), 0).toLocaleString());
    show('s-bytes', state.bytes.toLocaleString());
    dirty = true;
  });
  progressive.addEventListener('complete', (e) => {
    state.timings.full = performance.now() - started;
    state.stats = e.stats;  // the worker's: bytes, workerMs (its open to its last level), levels
    drawnMarks.add('fullDrawn');
    state.bytes = e.stats.bytes;
    state.status = 'complete';
    show('s-state', 'complete');
    show('s-full', state.timings.full.toFixed(0) + ' ms');
    show('s-bytes', state.bytes.toLocaleString());
    dirty = true;
  });
  progressive.addEventListener('error', (e) => fail(e.error));
  try {
    const gltf = await progressive.load(loader, url);
    state.timings.base = performance.now() - started;
    if (state.status === 'loading') state.status = 'base';
    show('s-state', state.status);
    show('s-base', state.timings.base.toFixed(0) + ' ms');
    const root = gltf.scene || gltf.scenes[0];
    scene.add(root);
    frameObject(root);
    drawnMarks.add('baseDrawn');
    current = { progressive, root };
    // A file without progressive primitives is complete at its base.
    if (progressive.geometries.size === 0) {
      state.status = 'complete';
      state.timings.full = state.timings.base;
      drawnMarks.add('fullDrawn');
      show('s-state', 'complete');
    }
  } catch (e) {
    fail(e);
  }
}

function begin() {
  Object.assign(state, { status: 'loading', streams: {}, timings: {}, bytes: 0, error: null });
  $('error').textContent = '';
  for (const id of ['s-level', 's-vertices', 's-predicted', 's-bytes', 's-base', 's-full']) show(id, '-');
  show('s-state', 'loading');
  drawnMarks.clear();
  started = performance.now();
}

// The reference: the Draco .glb export through three.js alone. Its first
// view is its full view.
async function loadDraco() {
  const asset = $('asset').value;
  const version = $('version').value.trim() || 'latest';
  begin();
  const url = new URL(`v1/assets/${encodeURIComponent(asset)}/versions/${version}/draco`, location.href).href;
  const loader = new GLTFLoader().setDRACOLoader(dracoLoader);
  loader.setRequestHeader(headers());
  try {
    const gltf = await loader.loadAsync(url, (e) => { state.bytes = e.loaded; });
    state.timings.base = state.timings.full = performance.now() - started;
    const root = gltf.scene || gltf.scenes[0];
    scene.add(root);
    frameObject(root);
    drawnMarks.add('baseDrawn');
    drawnMarks.add('fullDrawn');
    current = { progressive: { dispose() {} }, root };
    state.status = 'complete';
    show('s-state', 'complete');
    show('s-base', state.timings.base.toFixed(0) + ' ms');
    show('s-full', state.timings.full.toFixed(0) + ' ms');
    show('s-bytes', state.bytes.toLocaleString());
  } catch (e) {
    fail(e);
  }
}

function fail(e) {
  state.status = 'error';
  state.error = String(e && e.message ? e.message : e);
  show('s-state', 'error');
  $('error').textContent = state.error;
}

for (const key of ['version', 'mode', 'lod', 'loss']) if (params.has(key)) $(key).value = params.get(key);
if (params.has('tint')) $('tint').checked = params.get('tint') !== '0';
$('load').addEventListener('click', load);
Promise.all([listAssets(), decodersReady]).then(() => {
  if (params.get('auto') === '1') load();
});
