// The page bundled from the installed npm package (npm_package_run.sh), in
// Debian's Chromium driven by puppeteer-core: the page (npm_package/app.js)
// loads a progressive asset from a real `meshstream serve` with the
// package's three.js plugin, and this checks:
//   - the base showed: the scene held the base mesh's vertex and face
//     counts (the native decode's level 0) and the canvas was not blank;
//   - every stream's levels came in order, and refinement reached the last
//     level, with the vertex and face counts of the native decode
//     (`meshstream decode --json` of the file the server serves);
//   - the scene's geometry after 'complete' holds and draws exactly those
//     (its triangles use the last refinement's vertices) and the canvas is
//     not blank;
//   - the page logged no error and threw nothing.
// A browser that cannot start fails the test with the reason. Timeouts only
// guard against hangs.
// usage: node npm_package_test.mjs --page URL --asset-url URL --cli PATH/TO/meshstream
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { execFileSync } from 'node:child_process';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromiumPath, flagTaker, launchChromium } from '../../web/tools/node_support.mjs';

const args = process.argv.slice(2);
const take = flagTaker(args);
const pageUrl = take('--page');
const assetUrl = take('--asset-url');
const cli = take('--cli');

// The native decode of the file the server serves: every level's vertex count and the final counts.
async function nativeDecode(work) {
  const response = await fetch(assetUrl);
  if (!response.ok) throw new Error(`${assetUrl}: HTTP ${response.status} ${await response.text()}`);
  const file = join(work, 'asset.glb');
  writeFileSync(file, new Uint8Array(await response.arrayBuffer()));
  const out = execFileSync(cli, ['decode', file, '-o', join(work, 'decoded.ply'), '--json'], { encoding: 'utf8' });
  const d = JSON.parse(out.trim().split('\n').pop());
  const baseOut = execFileSync(cli, ['decode', file, '-o', join(work, 'base.ply'), '--lod', '0', '--json'], { encoding: 'utf8' });
  const b = JSON.parse(baseOut.trim().split('\n').pop());
  return { vertices: d.vertices, faces: d.faces, levels: d.levels, levelVertices: d.level_vertices,
           baseVertices: b.vertices, baseFaces: b.faces };
}

async function main() {
  const work = mkdtempSync(join(tmpdir(), 'meshstream-npm-'));
  const failures = [];
  const fail = (why) => failures.push(why);
  let browser;
  try {
    const native = await nativeDecode(work);
    console.log(`npm_package_test: native decode: base ${native.baseVertices} vertices, ${native.baseFaces} faces; ` +
                `${native.levels} levels to ${native.vertices} vertices, ${native.faces} faces`);
    try {
      browser = await launchChromium({ width: 400, height: 300 });
    } catch (e) {
      console.error('npm_package_test: Chromium (' + chromiumPath() + ') did not start: ' + e.message +
                    '\n(scripts/install-deps installs the chromium package)');
      return 1;
    }
    const page = await browser.newPage();
    const logs = [];
    page.on('console', (m) => {
      logs.push(m.type() + ': ' + m.text());
      if (m.type() === 'error') fail('the page logged an error: ' + m.text());
    });
    page.on('pageerror', (e) => fail('the page threw: ' + e.message));
    page.on('requestfailed', (r) => fail(`a request failed: ${r.url()} (${r.failure() && r.failure().errorText})`));
    page.on('response', (r) => { if (r.status() >= 400) fail(`HTTP ${r.status()} for ${r.url()}`); });
    const url = new URL(pageUrl);
    url.searchParams.set('url', new URL(assetUrl).pathname);
    await page.goto(url.href, { waitUntil: 'load' });
    await page.waitForFunction(() => window.meshstreamTest && ['complete', 'error'].includes(window.meshstreamTest.status),
                               { timeout: 120000, polling: 50 });
    const state = await page.evaluate(() => JSON.parse(JSON.stringify(window.meshstreamTest)));
    console.log('npm_package_test: base ' + JSON.stringify(state.base) + ', final ' + JSON.stringify(state.final) +
                ', ' + state.levels.length + ' levels shown');
    if (state.status !== 'complete') {
      fail('status ' + state.status + (state.error ? ': ' + state.error : ''));
    } else {
      const base = state.base;
      if (!base || base.vertices !== native.baseVertices || base.faces !== native.baseFaces) {
        fail(`the base: ${JSON.stringify(base)}; native ${native.baseVertices} vertices, ${native.baseFaces} faces`);
      }
      if (!(base && base.drawn > 0.01)) fail(`the base drew ${base ? base.drawn : 'nothing'} of the canvas`);
      const streams = [...new Set(state.levels.map((l) => l.streamId))];
      if (streams.length !== 1) fail(`levels of streams ${JSON.stringify(streams)}; the asset has one`);
      const levels = state.levels.map((l) => l.level);
      if (!levels.every((l, k) => k === 0 || l > levels[k - 1])) fail('levels out of order: ' + JSON.stringify(levels));
      for (const l of state.levels) {
        if (l.levels !== native.levels) fail(`level ${l.level} says ${l.levels} levels; native ${native.levels}`);
        if (l.vertices !== native.levelVertices[l.level]) {
          fail(`level ${l.level}: ${l.vertices} vertices; native ${native.levelVertices[l.level]}`);
        }
      }
      const last = state.levels[state.levels.length - 1];
      if (!last || last.level !== native.levels || last.vertices !== native.vertices || last.faces !== native.faces) {
        fail(`the last level: ${JSON.stringify(last)}; native level ${native.levels}, ${native.vertices} vertices, ${native.faces} faces`);
      }
      const final = state.final;
      // Its triangles use the vertices the last refinement added, and none beyond.
      const before = native.levelVertices[native.levels - 1];
      if (!final || final.vertices !== native.vertices || final.faces !== native.faces ||
          !(final.referenced > before && final.referenced <= native.vertices)) {
        fail(`the scene after 'complete': ${JSON.stringify(final)}; native ${native.vertices} vertices ` +
             `(${before} before the last refinement), ${native.faces} faces`);
      }
      if (!(final && final.drawn > 0.01)) fail(`the full mesh drew ${final ? final.drawn : 'nothing'} of the canvas`);
    }
    if (failures.length) console.error('  page log:\n    ' + logs.slice(-20).join('\n    '));
  } finally {
    if (browser) await browser.close();
    rmSync(work, { recursive: true, force: true });
  }
  for (const f of failures) console.error('npm_package_test: ' + f);
  if (failures.length === 0) console.log('npm_package_test: ok');
  return failures.length ? 1 : 0;
}

main().then((rc) => process.exit(rc), (e) => {
  console.error('npm_package_test: ' + (e && e.stack ? e.stack : e));
  process.exit(1);
});
