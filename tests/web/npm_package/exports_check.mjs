// The installed package's entry points, run from the project that installed
// it (tests/web/npm_package_run.sh copies this file there, so that
// '@meshstream/web' resolves through its node_modules and the package's
// `exports`): each of '.', './plugin' and './client' imports under node with
// the names the package documents; './worker' and './wasm' resolve to files,
// and the wasm module is emscripten's factory. Then writes exports_check.ts:
// the names each entry exports at run time as a Record over `keyof typeof`
// the entry, so that tsc fails when the declarations (types/*.d.ts) declare a
// value the module does not export, or miss one it does.
// usage (in the project): node exports_check.mjs
import { existsSync, writeFileSync } from 'node:fs';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const require = createRequire(import.meta.url);
const expected = {
  '@meshstream/web': ['DecoderWorker', 'MeshstreamClient', 'MeshstreamProgressive', 'fetchPrefix', 'jobSpec', 'viewOfCamera'],
  '@meshstream/web/plugin': ['MeshstreamProgressive', 'viewOfCamera'],
  '@meshstream/web/client': ['DecoderWorker', 'MeshstreamClient', 'fetchPrefix', 'jobSpec'],
};
let failures = 0;
const fail = (why) => {
  console.error('exports_check: ' + why);
  ++failures;
};

const lines = ['// Written by exports_check.mjs: the names each entry exports at run time.'];
let n = 0;
for (const [entry, names] of Object.entries(expected)) {
  let keys;
  try {
    keys = Object.keys(await import(entry)).sort();
  } catch (e) {
    fail(`import('${entry}'): ${e.message}`);
    continue;
  }
  if (JSON.stringify(keys) !== JSON.stringify([...names].sort())) {
    fail(`${entry} exports ${JSON.stringify(keys)}, expected ${JSON.stringify(names)}`);
  }
  lines.push(`import * as entry${n} from '${entry}';`);
  lines.push(`export const names${n}: Record<keyof typeof entry${n}, true> = { ${keys.map((k) => k + ': true').join(', ')} };`);
  ++n;
}
for (const entry of ['@meshstream/web/worker', '@meshstream/web/wasm', '@meshstream/web/package.json']) {
  try {
    const file = fileURLToPath(import.meta.resolve(entry));
    if (!existsSync(file)) fail(`${entry} resolves to ${file}, which does not exist`);
  } catch (e) {
    fail(`${entry} does not resolve: ${e.message}`);
  }
}
try {
  const factory = require('@meshstream/web/wasm');
  if (typeof factory !== 'function') fail(`@meshstream/web/wasm is a ${typeof factory}, not the module's factory`);
} catch (e) {
  fail(`require('@meshstream/web/wasm'): ${e.message}`);
}
writeFileSync('exports_check.ts', lines.join('\n') + '\n');
process.exit(failures ? 1 : 0);
