// The README's uses of @meshstream/web, type-checked against the package's
// declarations (tsc --noEmit in tests/web/npm_package_run.sh, with
// @types/three): the plugin, the plain-JS client and every option they take.
import { PerspectiveCamera, Scene } from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { MeshstreamProgressive, viewOfCamera } from '@meshstream/web';
import type { MeshstreamProgressiveOptions, ProgressiveStats } from '@meshstream/web/plugin';
import { DecoderWorker, MeshstreamClient } from '@meshstream/web/client';
import type { MeshArrays, View, WorkerStats } from '@meshstream/web/client';

export async function threeLines(scene: Scene, camera: PerspectiveCamera, token: string): Promise<ProgressiveStats> {
  const shared = new DecoderWorker({ workerUrl: '/meshstream/src/worker.js',
                                     moduleUrls: { decoder: '/m.cjs', draco: '/d.js', dracoWasm: '/d.wasm' } });
  const options: MeshstreamProgressiveOptions = {
    workerUrl: new URL('/meshstream/src/worker.js', 'https://example.org/'),
    headers: { Authorization: 'Bearer ' + token },
    lod: -1,
    session: { url: 'wss://example.org/v1/stream', asset: 'bunny', version: 0, token, lod: 3 },
    loss: 0.1,
    seed: 7,
    tintPredicted: true,
    worker: shared,
    workers: 2,
    view: (gltf) => (gltf.scene ? viewOfCamera(camera, 640, 480) : null),
    viewIntervalMs: 500,
  };
  const progressive = new MeshstreamProgressive(options);
  const loader = new GLTFLoader().setDRACOLoader(new DRACOLoader().setDecoderPath('/draco/'));
  loader.register((parser) => progressive.plugin(parser));
  progressive.addEventListener('base', (e) => scene.add(e.gltf.scene));
  progressive.addEventListener('level', (e) => {
    const counts: number[] = [e.streamId, e.level, e.levels, e.vertices, e.faces, e.predictedVertices];
    const hash: string = e.hash;
    return [counts, hash];
  });
  progressive.addEventListener('complete', (e) => console.log(e.stats.bytes, e.stats.levels, e.timings.complete));
  progressive.addEventListener('error', (e) => console.error(e.error.message));
  const gltf = await progressive.load(loader, '/v1/assets/bunny/versions/1/progressive');
  scene.add(gltf.scene);
  const sent: boolean = progressive.setView(camera, 640, 480);
  const stats = await progressive.complete;
  for (const entry of progressive.geometries.values()) entry.geometry.computeBoundingSphere();
  progressive.dispose({ geometries: sent });
  return stats;
}

export async function otherEngines(view: View): Promise<number> {
  const client = await MeshstreamClient.open({ url: '/v1/assets/bunny/versions/1/progressive', headers: {}, lod: 5,
                                               view, workerUrl: '/meshstream/src/worker.js' });
  let total = 0;
  const upload = (arrays: MeshArrays | null) => { if (arrays) total += arrays.positions.length + arrays.indices.length; };
  client.on('base', () => client.primitives.forEach((p) => upload(p.arrays)))
    .on('level', ({ streamId, level, levels, mesh }) => { upload(mesh); return [streamId, level, levels]; })
    .on('complete', (stats: WorkerStats) => console.log(stats.bytes, stats.decodeMs, stats.source))
    .on('error', (error) => console.error(error.message));
  client.dispose();
  return total;
}
