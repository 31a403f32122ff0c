#!/usr/bin/env bash
# Regenerates the test vectors of docs/spec/progressive-format.md ("Test vector")
# from octahedron.obj with the meshstream CLI (build it first: make build):
#   tests/data/vector/regenerate.sh [path/to/meshstream]
# Writes, in the current format version (4), octahedron-qp8-bundled.glb (the
# loss-tolerant profile, bundled packing) and octahedron-qp8-reliable.glb
# (the reliable profile), each with its stream blob (the bufferView of
# MESHSTREAM_progressive) as .msps. The tests
# (tests/progressive/test_vector_test.cc) do not run this: they check that the
# encoder still writes exactly these bytes. Regenerate only for a new format
# version, keep the old vectors under their version's name (-v3, -v2, -v1:
# the same command with --format-version 3, 2 or 1, written when that version
# was current), and update the spec's hex walk-through with them.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cli="${1:-$here/../../../build/bin/meshstream}"
"$cli" encode "$here/octahedron.obj" -o "$here/octahedron-qp8-bundled.glb" \
  --qp 8 --levels 1 --profile loss-tolerant --packing bundled --packet-bytes 1200 --cl 7
"$cli" encode "$here/octahedron.obj" -o "$here/octahedron-qp8-reliable.glb" \
  --qp 8 --levels 1 --profile reliable --packet-bytes 1200 --cl 7
for name in octahedron-qp8-bundled octahedron-qp8-reliable; do
python3 - "$here/$name.glb" "$here/$name.msps" <<'PY'
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
done
