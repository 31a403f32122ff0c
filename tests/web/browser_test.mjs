// The viewer in a real browser (docs/design/web.md, "Tests"): Debian's Chromium,
// headless, driven by puppeteer-core, loads the viewer page from a real
// server and streams each asset by HTTP ranges and over a live WebSocket
// session. For every load it checks:
//   - the status reaches 'complete' without an error;
//   - every refined stream showed its levels in order (the page may skip
//     levels it had no frame for, never go back), each with the vertex and
//     face counts of that level (the wasm live decoder under node, itself
//     checked against the native one by wasm_decoder, gives every level's
//     counts), and ended at the native decoder's counts;
//   - the final arrays' hash (PrimitiveHash in wasm) equals the native
//     decode of the same file (meshstream_wasm_reference, the file fetched
//     from the same server);
//   - three.js drew something: the canvas holds pixels other than the
//     background (a blank or all-background picture fails);
//   - over a live session, the plugin sent the camera as a view at least
//     once; by ranges, the streams were read in the order of the camera's
//     view (view_order.js), split between two Web Workers when the file has
//     several streams (the meshes above are the same whatever the order);
// and saves a screenshot per load into --shots when given.
// A browser that cannot start fails the test with the reason.
//
// usage: node browser_test.mjs --base http://HOST:PORT/ --reference BIN --wasm MODULE
//          [--token T] [--shots DIR] [--modes ranges,live] ASSET...
import { mkdtempSync, writeFileSync, rmSync, mkdirSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { createRequire } from 'node:module';
import { parseGlb, progressivePrimitives } from '../../web/src/glb.js';
import { decodeDracoBase } from '../../web/src/draco_base.js';
import { LiveDecoder } from '../../web/src/decoder.js';
import { BlobReader } from '../../web/src/blob_reader.js';
import { chromiumPath, flagTaker, launchChromium } from '../../web/tools/node_support.mjs';

const require = createRequire(import.meta.url);

const args = process.argv.slice(2);
const take = flagTaker(args);
const base = take('--base');
const reference = take('--reference');
const wasmModule = take('--wasm');
const token = take('--token', '');
const shots = take('--shots', '');
const modes = take('--modes', 'ranges,live').split(',');
const assets = args;
if (assets.length === 0) throw new Error('no asset given');
const chromium = chromiumPath();

// The native decode of the file the server serves.
async function nativeHashes(asset, work) {
  const headers = token ? { Authorization: 'Bearer ' + token } : {};
  const url = new URL(`v1/assets/${encodeURIComponent(asset)}/versions/latest/progressive`, base);
  const response = await fetch(url, { headers });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status} ${await response.text()}`);
  const file = join(work, asset + '.glb');
  writeFileSync(file, new Uint8Array(await response.arrayBuffer()));
  const out = execFileSync(reference, [file, '--loss', '0', '--burst', '0', '--seed', '1'], { encoding: 'utf8' });
  const streams = {};
  for (const line of out.trim().split('\n')) {
    const [id, vertices, indices, hash] = line.split(' ');
    streams[id] = { vertices: Number(vertices), indices: Number(indices), hash, levels: [] };
  }
  // Every level's counts, from the live decoder under node.
  const bytes = new Uint8Array(await (await fetch(url, { headers })).arrayBuffer());
  for (const p of progressivePrimitives(parseGlb(bytes))) {
    const reader = new BlobReader();
    let live = null;
    const counts = () => {
      live.snapshot();
      const a = live.arrays();
      streams[p.streamId].levels.push({ vertices: a.vertices, faces: a.indices.length / 3 });
    };
    try {
      for (const e of reader.push(p.blob)) {
        if (e.kind === 'header') {
          live = new LiveDecoder(wasm.M, e.bytes, p.streamId);
          live.setBase(decodeDracoBase(wasm.D, p.base, p.ids));
          counts();
        } else if (e.kind === 'control') {
          live.control(e.bytes);
        } else if (e.kind === 'datagram') {
          live.datagram(e.bytes);
        } else {
          live.end(e.refinement, e.datagrams);
          live.poll();
          counts();
        }
      }
    } finally {
      if (live) live.close();
    }
  }
  return streams;
}

const wasm = {};

// Pixels of the WebGL canvas that are not the background, as a share.
function drawnShare() {
  const c = document.getElementById('view');
  const copy = document.createElement('canvas');
  copy.width = c.width;
  copy.height = c.height;
  const g = copy.getContext('2d');
  g.drawImage(c, 0, 0);
  const px = g.getImageData(0, 0, copy.width, copy.height).data;
  let other = 0;
  for (let i = 0; i < px.length; i += 4) {
    if (Math.abs(px[i] - 0x20) + Math.abs(px[i + 1] - 0x24) + Math.abs(px[i + 2] - 0x28) > 24) ++other;
  }
  return other / (px.length / 4);
}

async function main() {
  wasm.M = await require(resolve(wasmModule))();
  wasm.D = await require(join(new URL('../../web', import.meta.url).pathname, 'node_modules/draco3d')).createDecoderModule({});
  const work = mkdtempSync(join(tmpdir(), 'meshstream-browser-'));
  let browser;
  try {
    browser = await launchChromium();
  } catch (e) {
    console.error('browser_test: Chromium (' + chromium + ') did not start: ' + e.message +
                  '\n(scripts/install-deps installs the chromium package)');
    return 1;
  }
  let failures = 0;
  let viewOrderedLoads = 0;  // loads by ranges that read their blobs in the view's order
  try {
    if (shots) mkdirSync(shots, { recursive: true });
    for (const asset of assets) {
      const native = await nativeHashes(asset, work);
      for (const mode of modes) {
        const page = await browser.newPage();
        const logs = [];
        page.on('console', (m) => logs.push(m.type() + ': ' + m.text()));
        page.on('pageerror', (e) => logs.push('pageerror: ' + e.message));
        const fail = (why) => {
          console.error(`${asset} (${mode}): ${why}`);
          if (logs.length) console.error('  page log:\n    ' + logs.slice(-20).join('\n    '));
          ++failures;
        };
        try {
          // By ranges, a file's streams split between two Web Workers.
          const url = new URL(`?asset=${encodeURIComponent(asset)}&mode=${mode}&tint=0${mode === 'ranges' ? '&workers=2' : ''}` +
                              `${token ? '' : '&auto=1'}`, base);
          await page.goto(url.href, { waitUntil: 'load' });
          if (token) {
            // The token goes through the form, as a user would type it.
            await page.waitForFunction(() => window.meshstreamViewer.ready, { timeout: 60000 });
            await page.evaluate((t) => {
              document.getElementById('token').value = t;
              document.getElementById('load').click();
            }, token);
          }
          await page.waitForFunction(
            () => ['complete', 'error'].includes(window.meshstreamViewer.status), { timeout: 120000, polling: 50 });
          // Two frames after the last level, so the canvas shows it.
          await page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
          const state = await page.evaluate(() => JSON.parse(JSON.stringify(window.meshstreamViewer)));
          if (state.status !== 'complete') {
            fail('status ' + state.status + (state.error ? ': ' + state.error : ''));
            continue;
          }
          const ids = Object.keys(native);
          const got = Object.keys(state.streams);
          if (got.length !== ids.length) fail(`${got.length} streams refined, the file has ${ids.length}`);
          for (const id of ids) {
            const s = state.streams[id];
            if (!s) {
              fail('stream ' + id + ' never refined');
              continue;
            }
            const levels = s.levels.map((l) => l.level);
            const inOrder = levels.every((l, k) => k === 0 || l > levels[k - 1]);
            if (!inOrder) fail(`stream ${id}: levels out of order ${JSON.stringify(levels)}`);
            for (const l of s.levels) {
              const want = native[id].levels[l.level];
              if (!want || want.vertices !== l.vertices || want.faces !== l.faces) {
                fail(`stream ${id} level ${l.level}: ${l.vertices} vertices, ${l.faces} faces; ` +
                     `expected ${want ? want.vertices + ', ' + want.faces : 'no such level'}`);
              }
            }
            if (levels[levels.length - 1] !== native[id].levels.length - 1) {
              fail(`stream ${id}: ended at level ${levels[levels.length - 1]} of ${native[id].levels.length - 1}`);
            }
            const last = s.levels[s.levels.length - 1];
            if (last.vertices !== native[id].vertices || last.faces * 3 !== native[id].indices) {
              fail(`stream ${id}: ${last.vertices} vertices, ${last.faces} faces; native ${native[id].vertices}, ${native[id].indices / 3}`);
            }
            if (s.hash !== native[id].hash) fail(`stream ${id}: hash ${s.hash}, native ${native[id].hash}`);
          }
          // Ranges: the streams were fetched in the order of the camera's view
          // (when the prefix did not already hold every blob: source 'bytes').
          if (mode === 'ranges' && state.stats && state.stats.source === 'ranges') {
            ++viewOrderedLoads;
            if (!(Array.isArray(state.stats.viewOrder) && state.stats.viewOrder.length === ids.length)) {
              fail(`the ranges were not read in the view's order (${JSON.stringify(state.stats.viewOrder)})`);
            }
          }
          // Ranges: a file of several streams was decoded by two workers.
          if (mode === 'ranges' && ids.length > 1 && state.stats.workers !== 2) {
            fail(`${ids.length} streams decoded by ${state.stats.workers} workers, not 2`);
          }
          // Live: the plugin sent the camera to the session (the server orders by it).
          if (mode === 'live' && !(state.stats && state.stats.viewsSent >= 1)) {
            fail(`the plugin sent no view (${JSON.stringify(state.stats)})`);
          }
          const drawn = await page.evaluate(drawnShare);
          if (!(drawn > 0.005)) fail(`the canvas is blank (${(drawn * 100).toFixed(2)} % drawn)`);
          if (shots) await page.screenshot({ path: join(shots, `${asset}-${mode}.png`) });
          const levelCount = Object.values(state.streams).reduce((a, s) => a + s.levels.length, 0);
          console.log(`${asset} (${mode}): ${got.length} streams, ${levelCount} levels, base ${state.timings.base.toFixed(0)} ms, ` +
                      `full ${state.timings.full.toFixed(0)} ms, ${state.bytes} bytes, ${(drawn * 100).toFixed(1)} % drawn` +
                      (mode === 'live' ? `, ${state.stats.viewsSent} views sent, ${state.stats.levelPlans || 0} level plans` : ''));
        } catch (e) {
          fail(e.message);
        } finally {
          await page.close();
        }
      }
    }
    if (modes.includes('ranges') && viewOrderedLoads === 0) {
      console.error('browser_test: no load by ranges read its blobs by ranges (every prefix held them all)');
      ++failures;
    }
  } finally {
    await browser.close();
    rmSync(work, { recursive: true, force: true });
  }
  console.log(failures === 0 ? 'browser_test: every load passed' : `browser_test: ${failures} failures`);
  return failures === 0 ? 0 : 1;
}

main().then((code) => process.exit(code), (e) => {
  console.error('browser_test: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
