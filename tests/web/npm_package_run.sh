#!/usr/bin/env bash
# The npm package as a web developer gets it (docs/design/web.md, "The npm
# package"):
#   1. web/pack.sh packs @meshstream/web with the built decoder module
#      (npm pack); the tarball holds exactly the files the package names;
#   2. an empty project installs the tarball, three and esbuild (the versions
#      web/package.json pins; --prefer-offline: npm's cache has them after
#      scripts/install-deps) and @types/three;
#   3. every entry point ('.', './plugin', './client', './worker', './wasm')
#      resolves and imports under node with the names it documents, and
#      tsc --noEmit (web/node_modules' pinned TypeScript) compiles the
#      README's uses (npm_package/consumer.ts) and the run-time names of each
#      entry against the declarations (npm_package/exports_check.mjs);
#   4. esbuild bundles a page (npm_package/app.js: three.js, GLTFLoader,
#      DRACOLoader and the plugin from '@meshstream/web') into dist/, and the
#      package's `meshstream-web-assets` copies the worker and its
#      WebAssembly into dist/meshstream/ (three's Draco decoder into dist/draco/);
#   5. `meshstream serve --http-listen` serves dist/ as its --http-root (the
#      page and the asset route on one origin), the bunny ingested with
#      `meshstream ingest --wait`, and npm_package_test.mjs opens the page in
#      Debian's Chromium: the base shows, refinement reaches the last level
#      with the native decode's counts, no page error.
# Usage: tests/web/npm_package_run.sh PATH/TO/meshstream WASM_MODULE MODELS_DIR
# Exit: non-zero when a step fails (its output is shown).
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
web=$repo/web
# shellcheck source=../../testing/serve.sh
. "$repo/testing/serve.sh"
if [ $# -ne 3 ]; then
  echo "usage: $0 PATH/TO/meshstream WASM_MODULE MODELS_DIR" >&2
  exit 1
fi
bin=$(realpath "$1") module=$(realpath "$2") models=$3
say() { echo "npm_package_run.sh: $*"; }
die() {
  echo "npm_package_run.sh: $*" >&2
  exit 1
}
[ -f "$module" ] || die "$module is missing: run 'make wasm'"
for need in puppeteer-core esbuild three typescript @types/three; do
  [ -f "$web/node_modules/$need/package.json" ] || die "web/node_modules has no $need: run scripts/install-deps"
done
for var in $(compgen -e | grep '^MESHSTREAM_' | grep -v '^MESHSTREAM_TEST_'); do
  unset "$var"
done

tmp=$(mktemp -d)
cleanup() {
  serve_kill
  rm -rf "$tmp"
}
trap cleanup EXIT
# Each pinned version as web/package.json has it.
pin() { node -p 'const p = require(process.argv[1]); p.devDependencies[process.argv[2]] || p.dependencies[process.argv[2]]' \
  "$web/package.json" "$1"; }

# 1. The tarball, and what it holds.
tarball=$("$web/pack.sh" "$module" "$tmp/pack" 2>"$tmp/pack.err" | tail -n 1)
[ -f "$tarball" ] || die "web/pack.sh failed: $(cat "$tmp/pack.err")"
say "packed $(basename "$tarball"), $(($(stat -c %s "$tarball") / 1024)) KiB"
{
  printf 'package/%s\n' LICENSE README.md package.json wasm/meshstream_decoder.cjs
  (cd "$web" && printf 'package/%s\n' src/*.js types/*.d.ts bin/*.mjs)
} | sort >"$tmp/want.txt"
tar tzf "$tarball" | sort >"$tmp/have.txt"
if ! diff -u "$tmp/want.txt" "$tmp/have.txt" >"$tmp/files.diff"; then
  die "the tarball's files differ from what the package names (- missing, + unexpected):
$(cat "$tmp/files.diff")"
fi

# 2. An empty project installs it.
app=$tmp/app
mkdir -p "$app"
printf '{ "name": "npm-package-test", "private": true, "type": "module" }\n' >"$app/package.json"
if ! (cd "$app" && npm install --prefer-offline --no-audit --no-fund --loglevel=error "$tarball" \
      "three@$(pin three)" "esbuild@$(pin esbuild)" "@types/three@$(pin @types/three)") >"$tmp/npm.log" 2>&1; then
  die "npm install failed: $(tail -n 20 "$tmp/npm.log")"
fi
say "installed into an empty project: @meshstream/web, three $(pin three), esbuild $(pin esbuild)"

# 3. The entry points and the declarations.
rc=0
cp "$here"/npm_package/exports_check.mjs "$here"/npm_package/consumer.ts "$here"/npm_package/tsconfig.json "$app/"
(cd "$app" && node exports_check.mjs) || rc=1
if (cd "$app" && "$web/node_modules/.bin/tsc" -p tsconfig.json); then
  say "the declarations compile with the README's uses and match the entries' run-time names (tsc $(pin typescript))"
else
  echo "npm_package_run.sh: tsc --noEmit failed on the package's declarations" >&2
  rc=1
fi

# 4. The page, bundled; the worker's files beside it.
cp "$here/npm_package/app.js" "$app/"
mkdir -p "$app/dist/draco"
cp "$here/npm_package/index.html" "$app/dist/"
(cd "$app" && node_modules/.bin/esbuild app.js --bundle --format=esm --outfile=dist/main.js --log-level=warning) ||
  die "esbuild could not bundle the page"
(cd "$app" && node_modules/.bin/meshstream-web-assets dist/meshstream) || die "meshstream-web-assets failed"
cp "$app"/node_modules/three/examples/jsm/libs/draco/gltf/* "$app/dist/draco/"
say "bundled: dist/main.js $(($(stat -c %s "$app/dist/main.js") / 1024)) KiB"

# 5. A real server for the page and the asset, and Chromium.
grace=10
serve_start "$bin" "$tmp/server" --listen 127.0.0.1:0 --udp-listen off --http-listen 127.0.0.1:0 \
  --store "$tmp/store" --grace-period "$grace" --http-root "$app/dist"
serve_ready 60 || exit 1
grpc=$SERVE_GRPC http=$SERVE_HTTP
[ -n "$http" ] || die "the server's ready file names no HTTP address"
if ! "$bin" ingest "$models/stanford-bunny.obj" --asset bunny --wait --server "$grpc" >"$tmp/ingest.out" 2>&1; then
  serve_log
  die "ingesting the bunny failed: $(tail -n 5 "$tmp/ingest.out")"
fi
node "$here/npm_package_test.mjs" --page "http://$http/" \
  --asset-url "http://$http/v1/assets/bunny/versions/latest/progressive" --cli "$bin" || rc=1
if ! serve_stop $((grace + 5)); then
  echo "npm_package_run.sh: the server was still running $((grace + 5))s after SIGTERM" >&2
  rc=1
fi
if [ $rc -ne 0 ]; then serve_log; fi
exit $rc
