#!/usr/bin/env bash
# make bench-web (docs/web-benchmarks.md): starts `meshstream serve
# --http-listen 127.0.0.1:0` on a temporary store with the viewer's bundle,
# ingests the bunny, the horse and 2CylinderEngine, runs bench_web.mjs (the
# three pages in headless Chromium on loopback and on the shaped link, and
# the wasm decoder against the native one) and writes OUT_JSON.
# usage: bench/web/run.sh PATH/TO/meshstream REFERENCE_BIN WASM_MODULE MODELS_DIR OUT_JSON [bench_web.mjs options]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(realpath "$1") reference=$(realpath "$2") module=$(realpath "$3") models=$4 out=$5
shift 5
root=$(dirname "$(dirname "$bin")")/web
if [ ! -f "$root/index.html" ] || [ ! -f "$module" ]; then
  echo "bench-web: the viewer's bundle or the wasm module is missing: run 'make wasm'" >&2
  exit 1
fi
for var in $(compgen -e | grep '^MESHSTREAM_' || true); do unset "$var"; done
tmp=$(mktemp -d)
pid=""
cleanup() {
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then kill -TERM "$pid"; wait "$pid" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
"$bin" serve --listen 127.0.0.1:0 --udp-listen off --http-listen 127.0.0.1:0 --store "$tmp/store" \
  >"$tmp/server.out" 2>"$tmp/server.log" &
pid=$!
for _ in $(seq 600); do
  grep -q '^http on ' "$tmp/server.out" 2>/dev/null && break
  kill -0 "$pid" 2>/dev/null || { cat "$tmp/server.log" >&2; exit 1; }
  sleep 0.1
done
grpc=$(sed -n 's/^listening on //p' "$tmp/server.out" | head -1)
http=$(sed -n 's/^http on //p' "$tmp/server.out" | head -1)
assets=()
for m in stanford-bunny.obj horse.ply gltf/2CylinderEngine.glb; do
  name=$(basename "${m%.*}")
  "$bin" ingest "$models/$m" --asset "$name" --wait --server "$grpc" >/dev/null
  assets+=("$name")
done
node "$here/bench_web.mjs" --base "http://$http/" --reference "$reference" --wasm "$module" --out "$out" "$@" "${assets[@]}"
