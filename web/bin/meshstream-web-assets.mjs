#!/usr/bin/env node
// Copies what the decoder's Web Worker loads into a folder the page's server
// serves (README.md, "With a bundler"): a bundler bundles the page's code,
// not the worker, whose files are fetched at run time.
//
//   OUT/src/*.js                        the worker (src/worker.js) and the modules it imports
//   OUT/wasm/meshstream_decoder.cjs     the meshstream decoder (WebAssembly inside)
//   OUT/vendor/draco3d/                 draco3d's decoder and its .wasm (the package's dependency)
//
// The layout is the one worker.js finds its modules in by default, so the
// page gives only the worker's URL:
//   new MeshstreamProgressive({ workerUrl: '/OUT/src/worker.js' })
//
// usage: meshstream-web-assets OUT_DIR
import { copyFileSync, existsSync, mkdirSync, readdirSync } from 'node:fs';
import { createRequire } from 'node:module';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const args = process.argv.slice(2);
if (args.length !== 1 || args[0].startsWith('-')) {
  console.error('usage: meshstream-web-assets OUT_DIR\n' +
                "copies the decoder's worker, its modules and the WebAssembly it loads into OUT_DIR;\n" +
                "then give the page's MeshstreamProgressive (or MeshstreamClient) { workerUrl: '<OUT_DIR's URL>/src/worker.js' }");
  process.exit(2);
}
const out = args[0];
const pkg = join(dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(import.meta.url);

const decoder = join(pkg, 'wasm', 'meshstream_decoder.cjs');
if (!existsSync(decoder)) {
  console.error(`meshstream-web-assets: ${decoder} is missing (in the meshstream repository, ` +
                'web/pack.sh stages the package with the module that make wasm builds)');
  process.exit(1);
}
let draco;
try {
  draco = dirname(require.resolve('draco3d/package.json'));
} catch (e) {
  console.error('meshstream-web-assets: draco3d is not installed (a dependency of @meshstream/web): ' + e.message);
  process.exit(1);
}

const copy = (from, dir, name) => {
  mkdirSync(join(out, dir), { recursive: true });
  copyFileSync(from, join(out, dir, name));
};
for (const name of readdirSync(join(pkg, 'src'))) {
  if (name.endsWith('.js')) copy(join(pkg, 'src', name), 'src', name);
}
copy(decoder, 'wasm', 'meshstream_decoder.cjs');
for (const name of ['draco_decoder_nodejs.js', 'draco_decoder.wasm', 'package.json']) {
  copy(join(draco, name), join('vendor', 'draco3d'), name);
}
console.log(`meshstream-web-assets: the worker in ${join(out, 'src', 'worker.js')} ` +
            "(the page's option workerUrl: that file's URL)");
