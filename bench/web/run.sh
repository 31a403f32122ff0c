#!/usr/bin/env bash
# make bench-web (docs/results/web-benchmarks.md): starts `meshstream serve
# --http-listen 127.0.0.1:0` on a temporary store with the viewer's bundle,
# ingests the bunny, the horse and 2CylinderEngine, runs bench_web.mjs (the
# three pages in headless Chromium on loopback and on the shaped link, and
# the wasm decoder against the native one) and writes OUT_JSON.
# usage: bench/web/run.sh PATH/TO/meshstream REFERENCE_BIN WASM_MODULE MODELS_DIR OUT_JSON [bench_web.mjs options]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../../testing/serve.sh
. "$here/../../testing/serve.sh"
bin=$(realpath "$1") reference=$(realpath "$2") module=$(realpath "$3") models=$4 out=$5
shift 5
root=$(dirname "$(dirname "$bin")")/web
if [ ! -f "$root/index.html" ] || [ ! -f "$module" ]; then
  echo "bench-web: the viewer's bundle or the wasm module is missing: run 'make wasm'" >&2
  exit 1
fi
for var in $(compgen -e | grep '^MESHSTREAM_' || true); do unset "$var"; done
tmp=$(mktemp -d)
cleanup() {
  serve_stop || true
  rm -rf "$tmp"
}
trap cleanup EXIT
serve_start "$bin" "$tmp/server" --listen 127.0.0.1:0 --udp-listen off --http-listen 127.0.0.1:0 --store "$tmp/store"
serve_ready 60
grpc=$SERVE_GRPC http=$SERVE_HTTP
assets=()
for m in stanford-bunny.obj horse.ply gltf/2CylinderEngine.glb; do
  name=$(basename "${m%.*}")
  "$bin" ingest "$models/$m" --asset "$name" --wait --server "$grpc" >/dev/null
  assets+=("$name")
done
node "$here/bench_web.mjs" --base "http://$http/" --reference "$reference" --wasm "$module" --out "$out" "$@" "${assets[@]}"
