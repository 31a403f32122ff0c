// The browser benchmark (make bench-web, docs/results/web-benchmarks.md): in headless
// Chromium (Debian's, driven by puppeteer-core), the viewer page of a real
// `meshstream serve --http-listen` loads each asset
//   - `draco`:  the Draco .glb export through three.js's GLTFLoader and
//               DRACOLoader alone (the reference: first view = full view),
//   - `ranges`: the progressive .glb by HTTP ranges with the meshstream plugin,
//   - `live`:   the same, its refinements from a live session over WebSocket,
// on loopback and on a shaped link (a user-space proxy: `--rate` Mbit/s each
// way, shared by every connection, and `--delay-ms` each way), each kind in
// turn within a round, `--runs` rounds, a fresh browser context (no cache)
// per load. Time starts when the page starts the load (the page, three.js
// and both decoders are loaded before, and the page had `--settle-ms` to
// settle, as a user's page has before a click): first view = the first frame that
// shows the base (`baseDrawn`), full = the first frame that shows every
// refinement (`fullDrawn`). Also, in node, the wasm decoder against the
// native one on the same files (the whole decode: Draco base and stream).
// Writes JSON: every load, and medians with the ratios to Draco.
//
// usage: node bench_web.mjs --base http://HOST:PORT/ --reference BIN --wasm MODULE
//          --out FILE.json [--runs 5] [--rate 20] [--delay-ms 20] [--token T] ASSET...
import { writeFileSync, mkdtempSync, rmSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import net from 'node:net';
import { parseGlb, progressivePrimitives } from '../../web/src/glb.js';
import { decodeDracoBase } from '../../web/src/draco_base.js';
import { StreamDecoder } from '../../web/src/decoder.js';
import { flagTaker, launchChromium } from '../../web/tools/node_support.mjs';

const require = createRequire(import.meta.url);

const args = process.argv.slice(2);
const take = flagTaker(args);
const base = take('--base');
const reference = take('--reference');
const wasm = take('--wasm');
const out = take('--out');
const runs = Number(take('--runs', '5'));
const rateMbit = Number(take('--rate', '20'));
const delayMs = Number(take('--delay-ms', '20'));
const token = take('--token', '');
const decodeRuns = Number(take('--decode-runs', '9'));
const settleMs = Number(take('--settle-ms', '1000'));
const assets = args;
const kinds = ['draco', 'ranges', 'live'];
const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? (s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2) : null;
};

// One bottleneck link, each direction its own queue at `rate` shared by
// every connection, then `delay` of propagation. Bytes keep their order per
// connection; a connection with more than 1 MiB queued stops being read
// (TCP's flow control pushes back on its sender).
function shapedProxy(upstream, rateBps, delay) {
  const link = { up: 0, down: 0 };  // when each direction's queue is free (ms, performance.now)
  // Each direction of a connection: a FIFO of chunks with their release
  // times, drained in order by one timer (timers of different delays may
  // fire out of order; TCP bytes must not).
  const forward = (from, to, dir) => {
    const queue = [];
    let queued = 0;
    let timer = null;
    let ended = false;
    const drain = () => {
      timer = null;
      const now = performance.now();
      while (queue.length && queue[0].at <= now) {
        const { chunk } = queue.shift();
        to.write(chunk);
        queued -= chunk.byteLength;
      }
      if (queued <= 1 << 20) from.resume();
      if (queue.length) {
        timer = setTimeout(drain, Math.max(0, queue[0].at - now));
      } else if (ended) {
        to.end();
      }
    };
    from.on('data', (chunk) => {
      const now = performance.now();
      const start = Math.max(now, link[dir]);
      link[dir] = start + (chunk.byteLength * 8 * 1000) / rateBps;
      queue.push({ chunk, at: link[dir] + delay });
      queued += chunk.byteLength;
      if (queued > 1 << 20) from.pause();
      if (timer === null) timer = setTimeout(drain, Math.max(0, queue[0].at - now));
    });
    from.on('end', () => {
      ended = true;
      if (timer === null) drain();
    });
    from.on('error', () => to.destroy());
  };
  const server = net.createServer((client) => {
    client.setNoDelay(true);
    const up = net.connect(upstream.port, upstream.hostname, () => up.setNoDelay(true));
    forward(client, up, 'up');
    forward(up, client, 'down');
    client.on('close', () => up.destroy());
    up.on('close', () => client.destroy());
  });
  return new Promise((res) => server.listen(0, '127.0.0.1', () => res(server)));
}

async function fetchFile(asset, format) {
  const response = await fetch(new URL(`v1/assets/${asset}/versions/latest/${format}`, base),
                               { headers: token ? { Authorization: 'Bearer ' + token } : {} });
  if (!response.ok) throw new Error(`${asset} ${format}: HTTP ${response.status}`);
  return new Uint8Array(await response.arrayBuffer());
}

// The whole decode (the Draco base and the stream) natively and in wasm.
async function decodeTimes(work) {
  const M = await require(resolve(wasm))();
  const D = await require('../../web/node_modules/draco3d').createDecoderModule({});
  const rows = [];
  for (const asset of assets) {
    const bytes = await fetchFile(asset, 'progressive');
    const file = join(work, asset + '.glb');
    writeFileSync(file, bytes);
    const nativeOut = execFileSync(reference, [file, '--repeat', String(decodeRuns)], { encoding: 'utf8' });
    const nativeMs = Number(/time_ms ([0-9.]+)/.exec(nativeOut)[1]);
    const prims = progressivePrimitives(parseGlb(bytes));
    const times = [];
    for (let r = 0; r <= decodeRuns; ++r) {
      const t0 = performance.now();
      for (const p of prims) {
        const d = new StreamDecoder(M, p.blob, p.streamId);
        try {
          d.setBase(decodeDracoBase(D, p.base, p.ids));
          d.decode({ reliable: p.reliable });
        } finally {
          d.close();
        }
      }
      if (r > 0) times.push(performance.now() - t0);  // the first run compiles the module's hot code
    }
    const wasmMs = median(times);
    rows.push({ asset, native_ms: nativeMs, wasm_ms: wasmMs, ratio: wasmMs / nativeMs });
    console.log(`decode ${asset}: native ${nativeMs.toFixed(1)} ms, wasm ${wasmMs.toFixed(1)} ms (${(wasmMs / nativeMs).toFixed(2)} x)`);
  }
  return rows;
}

async function loadOnce(browser, pageBase, asset, kind) {
  const context = await browser.createBrowserContext();
  const page = await context.newPage();
  try {
    const url = new URL(`?asset=${encodeURIComponent(asset)}&mode=${kind}&tint=0`, pageBase);
    await page.goto(url.href, { waitUntil: 'load', timeout: 120000 });
    // The page open and settled, as a user finds it: both decoders loaded
    // (the worker's warmed up), then a second for the engine's background
    // compilation to finish, then the click.
    await page.waitForFunction(() => window.meshstreamViewer.ready, { timeout: 120000 });
    await new Promise((r) => setTimeout(r, settleMs));
    await page.evaluate((t) => {
      document.getElementById('token').value = t;
      document.getElementById('load').click();
    }, token);
    await page.waitForFunction(() => ['complete', 'error'].includes(window.meshstreamViewer.status) &&
                                     (window.meshstreamViewer.status === 'error' || window.meshstreamViewer.timings.fullDrawn !== undefined),
                               { timeout: 120000, polling: 20 });
    const state = await page.evaluate(() => JSON.parse(JSON.stringify(window.meshstreamViewer)));
    if (state.status !== 'complete') throw new Error(`${asset} ${kind}: ${state.error}`);
    return { first_ms: state.timings.baseDrawn, full_ms: state.timings.fullDrawn, bytes: state.bytes,
             worker_ms: state.stats ? state.stats.workerMs : null, levels: state.stats ? state.stats.levels : null };
  } finally {
    await context.close();
  }
}

async function main() {
  const work = mkdtempSync(join(tmpdir(), 'meshstream-bench-web-'));
  const result = {
    config: { runs, rate_mbit: rateMbit, delay_ms: delayMs, settle_ms: settleMs, assets, kinds, chromium: '',
              date: new Date().toISOString() },
    decode: [], loads: [], summary: [], failures: [],
  };
  let proxy = null;
  let browser = null;
  try {
    result.decode = await decodeTimes(work);
    proxy = await shapedProxy(new URL(base), rateMbit * 1e6, delayMs);
    const shapedBase = `http://127.0.0.1:${proxy.address().port}/`;
    browser = await launchChromium();
    result.config.chromium = await browser.version();
    for (const [network, pageBase] of [['loopback', base], ['shaped', shapedBase]]) {
      for (const asset of assets) {
        for (let run = 0; run < runs; ++run) {
          for (const kind of kinds) {
            // A load that fails (a renderer that crashed, a wait that broke) is
            // counted and tried again, at most twice.
            let r = null;
            for (let attempt = 0; r === null; ++attempt) {
              try {
                r = await loadOnce(browser, pageBase, asset, kind);
              } catch (e) {
                result.failures.push({ network, asset, kind, run, attempt, error: String(e.message || e) });
                console.error(`${network} ${asset} ${kind} run ${run}: failed (${e.message}), attempt ${attempt + 1}`);
                if (attempt >= 2) throw e;
              }
            }
            result.loads.push(Object.assign({ network, asset, kind, run }, r));
            console.log(`${network} ${asset} ${kind} run ${run}: first ${r.first_ms.toFixed(0)} ms, full ${r.full_ms.toFixed(0)} ms, ${r.bytes} bytes`);
          }
        }
        const of = (kind, key) => median(result.loads.filter((l) => l.network === network && l.asset === asset && l.kind === kind).map((l) => l[key]));
        const draco = of('draco', 'full_ms');
        for (const kind of kinds) {
          result.summary.push({
            network, asset, kind, first_ms: of(kind, 'first_ms'), full_ms: of(kind, 'full_ms'), bytes: of(kind, 'bytes'),
            first_vs_draco: of(kind, 'first_ms') / draco, full_vs_draco: of(kind, 'full_ms') / draco,
          });
        }
      }
    }
  } finally {
    if (browser) await browser.close();
    if (proxy) proxy.close();
    rmSync(work, { recursive: true, force: true });
  }
  writeFileSync(out, JSON.stringify(result, null, 2) + '\n');
  console.log('bench_web: wrote ' + out);
  return 0;
}

main().then((code) => process.exit(code), (e) => {
  console.error('bench_web: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
