#!/usr/bin/env bash
# The wasm decoder against the native one (docs/design/web.md, "Tests"): every shared
# model (and the glTF scenes) encoded by the CLI into a temporary folder, then
# web/test/wasm_vs_native.mjs decodes each with the wasm module (the base by
# draco3d) and compares it with meshstream_wasm_reference (the native
# DecodeProgressiveGlb), without loss, at 12 % random loss and in bursts.
# usage: run.sh MESHSTREAM_CLI REFERENCE_BIN WASM_MODULE MODELS_DIR
set -euo pipefail
cli=$1 reference=$2 module=$3 models=$4
root="$(cd "$(dirname "$0")/../.." && pwd)"
if [ ! -f "$module" ]; then
  echo "wasm_decoder: $module is missing: build it with 'make wasm' (Debian's emscripten, scripts/install-deps)" >&2
  exit 1
fi
if ! command -v node >/dev/null 2>&1; then
  echo "wasm_decoder: node is missing (scripts/install-deps)" >&2
  exit 1
fi
if [ ! -f "$root/web/node_modules/draco3d/package.json" ]; then
  echo "wasm_decoder: web/node_modules has no draco3d: run scripts/install-deps" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
files=()
for m in stanford-bunny.obj horse.ply fandisk.obj rocker-arm.obj spot.obj gltf/2CylinderEngine.glb gltf/BoxTextured.glb; do
  out="$work/$(basename "${m%.*}").glb"
  # Both profiles in one file (what the server stores): the test decodes each.
  if ! log=$("$cli" encode --profile both "$models/$m" -o "$out" 2>&1); then
    echo "wasm_decoder: encoding $m failed: $log" >&2
    exit 1
  fi
  files+=("$out")
done
exec node "$root/web/test/wasm_vs_native.mjs" --wasm "$module" --reference "$reference" "${files[@]}"
