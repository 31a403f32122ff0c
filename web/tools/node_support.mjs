// What the node scripts around the browser path share (tests/web,
// bench/web, web/tools): reading `--flag value` options, and starting
// Debian's Chromium headless with software WebGL (SwiftShader), as root
// (no sandbox) and without /dev/shm (containers).
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const puppeteer = require('../node_modules/puppeteer-core');

// take(flag, fallback): the value after `flag`, removed from `args`; throws
// when it is missing and there is no fallback. What is left in `args` are
// the positional arguments.
export function flagTaker(args) {
  return (flag, fallback) => {
    const i = args.indexOf(flag);
    if (i < 0 || i + 1 >= args.length) {
      if (fallback === undefined) throw new Error('missing ' + flag);
      return fallback;
    }
    const v = args[i + 1];
    args.splice(i, 2);
    return v;
  };
}

// $CHROMIUM, else /usr/bin/chromium (scripts/install-deps installs it).
export function chromiumPath() {
  return process.env.CHROMIUM || '/usr/bin/chromium';
}

export function launchChromium({ width = 800, height = 600 } = {}) {
  return puppeteer.launch({
    executablePath: chromiumPath(),
    headless: true,
    args: ['--no-sandbox', '--disable-dev-shm-usage', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
           '--ignore-gpu-blocklist', `--window-size=${width},${height}`],
    defaultViewport: { width, height },
  });
}
