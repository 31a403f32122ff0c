// Opens the viewer of a running `meshstream serve --http-listen` in headless
// Chromium, loads one asset (by ranges or live), waits until it is complete
// and saves a screenshot: what `make demo` shows of the browser path.
// usage: node web/tools/screenshot.mjs --base http://HOST:PORT/ --asset NAME --out FILE.png
//          [--mode ranges|live] [--token T]
// Prints one line: the mode, levels, time to base and to full, bytes, the file.
import { flagTaker, launchChromium } from './node_support.mjs';

const args = process.argv.slice(2);
const take = flagTaker(args);
const base = take('--base'), asset = take('--asset'), out = take('--out');
const mode = take('--mode', 'live'), token = take('--token', '');

async function main() {
  const browser = await launchChromium({ width: 1024, height: 640 });
  try {
    const page = await browser.newPage();
    const url = new URL(`?asset=${encodeURIComponent(asset)}&mode=${mode}&tint=1${token ? '' : '&auto=1'}`, base);
    await page.goto(url.href, { waitUntil: 'load' });
    if (token) {
      await page.waitForFunction(() => window.meshstreamViewer.ready, { timeout: 60000 });
      await page.evaluate((t) => { document.getElementById('token').value = t; document.getElementById('load').click(); }, token);
    }
    await page.waitForFunction(() => ['complete', 'error'].includes(window.meshstreamViewer.status) &&
                                     (window.meshstreamViewer.status === 'error' || window.meshstreamViewer.timings.fullDrawn !== undefined),
                               { timeout: 120000, polling: 50 });
    const state = await page.evaluate(() => JSON.parse(JSON.stringify(window.meshstreamViewer)));
    if (state.status !== 'complete') throw new Error(state.error || state.status);
    await page.screenshot({ path: out });
    const levels = Object.values(state.streams).reduce((a, s) => a + s.levels.length, 0);
    console.log(`${asset} in the browser (${mode}): ${levels} levels shown, base drawn after ${state.timings.baseDrawn.toFixed(0)} ms, ` +
                `full after ${state.timings.fullDrawn.toFixed(0)} ms, ${state.bytes} bytes; screenshot ${out}`);
  } finally {
    await browser.close();
  }
}

main().then(() => process.exit(0), (e) => {
  console.error('screenshot: ' + (e && e.message ? e.message : e));
  process.exit(1);
});
