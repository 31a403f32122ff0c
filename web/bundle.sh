#!/usr/bin/env bash
# Assembles the viewer and the npm package's browser files into one folder,
# the static root `meshstream serve --http-listen` serves at / (docs/design/web.md,
# "The bundle"): the viewer page, web/src, the wasm decoder from build-wasm/,
# and, from web/node_modules (npm, pinned in web/package.json; nothing is
# vendored in the repository), the parts of three.js and draco3d the page
# and the worker load.
# usage: web/bundle.sh WASM_MODULE OUT_DIR
set -euo pipefail
module=$1 out=$2
web="$(cd "$(dirname "$0")" && pwd)"
nm="$web/node_modules"
for need in "$module" "$nm/three/build/three.module.js" "$nm/draco3d/draco_decoder_nodejs.js"; do
  if [ ! -f "$need" ]; then
    echo "bundle.sh: $need is missing (make wasm builds the module; scripts/install-deps installs web/node_modules)" >&2
    exit 1
  fi
done
tmp="$out.tmp.$$"
rm -rf "$tmp"
mkdir -p "$tmp/src" "$tmp/wasm" "$tmp/vendor/draco3d" "$tmp/vendor/three/build" \
  "$tmp/vendor/three/examples/jsm/loaders" "$tmp/vendor/three/examples/jsm/utils" \
  "$tmp/vendor/three/examples/jsm/controls" "$tmp/vendor/three/examples/jsm/libs/draco/gltf"
cp "$web"/viewer/* "$tmp/"
cp "$web"/src/*.js "$tmp/src/"
cp "$module" "$tmp/wasm/meshstream_decoder.cjs"
cp "$nm/draco3d/draco_decoder_nodejs.js" "$nm/draco3d/draco_decoder.wasm" "$nm/draco3d/package.json" "$tmp/vendor/draco3d/"
cp "$nm/three/LICENSE" "$nm/three/package.json" "$tmp/vendor/three/"
cp "$nm/three/build/three.module.js" "$nm/three/build/three.core.js" "$tmp/vendor/three/build/"
jsm="$nm/three/examples/jsm"
cp "$jsm/loaders/GLTFLoader.js" "$jsm/loaders/DRACOLoader.js" "$tmp/vendor/three/examples/jsm/loaders/"
cp "$jsm/utils/BufferGeometryUtils.js" "$jsm/utils/SkeletonUtils.js" "$tmp/vendor/three/examples/jsm/utils/"
cp "$jsm/controls/OrbitControls.js" "$tmp/vendor/three/examples/jsm/controls/"
cp "$jsm"/libs/draco/gltf/* "$tmp/vendor/three/examples/jsm/libs/draco/gltf/"
rm -rf "$out"
mv "$tmp" "$out"
