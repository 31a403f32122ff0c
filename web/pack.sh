#!/usr/bin/env bash
# Packs the npm package @meshstream/web (docs/design/web.md, "The npm
# package"): stages what web/package.json's `files` names (src/, types/, bin/)
# with the built decoder module (make wasm: build-wasm/meshstream_decoder.cjs,
# a build product, so packing takes a build), README.md, LICENSE and
# package.json itself (the source of truth, copied as it is), then runs
# `npm pack` there. Prints the tarball's path on its last line.
# The package's version must be the project's (CMakeLists.txt, project(VERSION)).
# usage: web/pack.sh WASM_MODULE OUT_DIR
set -euo pipefail
if [ $# -ne 2 ]; then
  echo "usage: $0 WASM_MODULE OUT_DIR" >&2
  exit 2
fi
module=$1 out=$2
web="$(cd "$(dirname "$0")" && pwd)"
if [ ! -s "$module" ]; then
  echo "pack.sh: $module is missing (make wasm builds it)" >&2
  exit 1
fi
project=$(sed -n 's/^project(meshstream VERSION \([0-9.]*\).*/\1/p' "$web/../CMakeLists.txt")
version=$(node -p 'require(process.argv[1]).version' "$web/package.json")
if [ -z "$project" ] || [ "$version" != "$project" ]; then
  echo "pack.sh: web/package.json has version $version, the project (CMakeLists.txt) ${project:-none}: make them equal" >&2
  exit 1
fi
mkdir -p "$out"
out=$(cd "$out" && pwd)
stage="$out/stage.$$"
rm -rf "$stage"
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/src" "$stage/wasm" "$stage/types" "$stage/bin"
cp "$web"/src/*.js "$stage/src/"
cp "$web"/types/*.d.ts "$stage/types/"
cp "$web"/bin/*.mjs "$stage/bin/"
cp "$module" "$stage/wasm/meshstream_decoder.cjs"
cp "$web/package.json" "$web/README.md" "$web/LICENSE" "$stage/"
tarball=$(cd "$stage" && npm pack --ignore-scripts --pack-destination "$out" --json | node -e '
  let s = ""; process.stdin.on("data", (d) => (s += d)).on("end", () => console.log(JSON.parse(s)[0].filename));')
echo "$out/$tarball"
