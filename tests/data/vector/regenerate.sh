#!/usr/bin/env bash
# Regenerates the test vector of docs/progressive-format.md ("Test vector")
# from octahedron.obj with the meshstream CLI (build it first: make build):
#   tests/data/vector/regenerate.sh [path/to/meshstream]
# Writes octahedron-qp8-bundled.glb and its stream blob (the bufferView of
# MESHSTREAM_progressive) as octahedron-qp8-bundled.msps, in the current
# format version (3). The test (tests/progressive/test_vector_test.cc) does not
# run this: it checks that the encoder still writes exactly these bytes.
# Regenerate only for a new format version, keep the old vector under its
# version's name (-v2, -v1: the same command with --format-version 2 or 1,
# written when that version was current), and update the spec's hex
# walk-through with it.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cli="${1:-$here/../../../build/bin/meshstream}"
"$cli" encode "$here/octahedron.obj" -o "$here/octahedron-qp8-bundled.glb" \
  --qp 8 --levels 1 --packing bundled --packet-bytes 1200 --cl 7
python3 - "$here/octahedron-qp8-bundled.glb" "$here/octahedron-qp8-bundled.msps" <<'PY'
import json, struct, sys
data = open(sys.argv[1], "rb").read()
json_len = struct.unpack_from("<I", data, 12)[0]
doc = json.loads(data[20:20 + json_len])
bin_start = 20 + json_len + 8
ext = doc["meshes"][0]["primitives"][0]["extensions"]["MESHSTREAM_progressive"]
view = doc["bufferViews"][ext["bufferView"]]
off = bin_start + view.get("byteOffset", 0)
open(sys.argv[2], "wb").write(data[off:off + view["byteLength"]])
PY
