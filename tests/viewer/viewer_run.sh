#!/usr/bin/env bash
# The native viewer end to end (examples/viewer, docs/engine-integration.md):
# a real `meshstream serve` (a temporary store; UDP paced at 1 Mbit/s a
# session, so that the bunny's levels come over several frames), the bunny and
# 2CylinderEngine ingested with `meshstream ingest --wait`; then the viewer
# under Xvfb with Mesa's software renderer (llvmpipe) streams each, renders
# each level, reads every upload back from the GPU (--verify) and writes its
# frames and its stats. Checks:
#   - it completes, and no GPU buffer ever differed from the SDK's view;
#   - per level shown: the vertex and index counts drawn equal the SDK's
#     views', and the vertices equal the stored file's at that level
#     (`meshstream decode --json`'s level_vertices) for the bunny; for the
#     engine only at the last level: a level of a scene is the one every
#     primitive has reached, and at the event others may be ahead (and with
#     the camera sent as the view the order is the view's); the frame is not blank
#     (at least 1 % of its pixels are not the background);
#   - the final frame equals a frame drawn from the session's export
#     (meshstream_viewer_reference: the .glb imported, drawn by the same
#     renderer with the same view-projection): at most 0.5 % of the pixels
#     differ by more than 8 levels in a channel;
#   - the frame budget: with --budget-us 0 every frame uploads exactly one
#     primitive, so each of the engine's events takes as many frames as it has
#     primitives (a count, not a time); the times the stream's part of each
#     frame took at the default budget are printed, bounded only as a hang;
#   - the bytes uploaded are fewer than re-uploading every level whole.
#   - predicted vertices are tinted: the bunny through a seeded lossy relay
#     (25 % each way, no parity, no repair) with --tint: the session ends with
#     predicted vertices, and its final frame has tinted pixels where the same
#     frame drawn untinted has none; the GPU buffers still equal the views.
# Usage: tests/viewer/viewer_run.sh MESHSTREAM VIEWER REFERENCE RELAY MODELS_DIR
#   MESHSTREAM_TEST_SHOTS  keep the frames there as PNG (bunny-final.png, ...)
# Exit: non-zero, saying which check failed, when one does.
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../../testing/serve.sh
. "$here/../../testing/serve.sh"
if [ $# -lt 5 ]; then
  echo "usage: $0 MESHSTREAM VIEWER REFERENCE RELAY MODELS_DIR" >&2
  exit 1
fi
bin=$(realpath "$1") viewer=$(realpath "$2") reference=$(realpath "$3") relay_bin=$(realpath "$4") models=$5
if ! command -v xvfb-run >/dev/null 2>&1; then
  echo "viewer_run.sh: xvfb-run is missing (scripts/install-deps installs xvfb and xauth)" >&2
  exit 1
fi
for var in $(compgen -e | grep '^MESHSTREAM_' | grep -v '^MESHSTREAM_TEST_'); do
  unset "$var"
done
tmp=$(mktemp -d)
relay_pid=""
cleanup() {
  [ -n "$relay_pid" ] && kill "$relay_pid" 2>/dev/null
  serve_kill
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "viewer_run.sh: $*" >&2
  serve_log 30
  exit 1
}

serve_start "$bin" "$tmp/server" --listen 127.0.0.1:0 --udp-listen 127.0.0.1:0 --store "$tmp/store" --workers 1 \
  --max-session-rate 1
serve_ready 60 || exit 1
ingest() {
  "$bin" ingest "$models/$2" --asset "$1" --server "$SERVE_GRPC" --wait >"$tmp/ingest-$1.out" 2>&1 ||
    fail "ingest of $2 failed: $(cat "$tmp/ingest-$1.out")"
  "$bin" export "$1" -o "$tmp/$1.progressive.glb" --format progressive --server "$SERVE_GRPC" >/dev/null ||
    fail "export of $1 failed"
  "$bin" decode "$tmp/$1.progressive.glb" -o "$tmp/$1.decoded.glb" --json >"$tmp/$1.decode.json" ||
    fail "decode of $1 failed"
}
ingest bunny stanford-bunny.obj
ingest engine gltf/2CylinderEngine.glb

# One Xvfb for everything; llvmpipe on every core.
run_x() {
  LIBGL_ALWAYS_SOFTWARE=1 GALLIUM_DRIVER=llvmpipe xvfb-run -a -s "-screen 0 800x600x24" "$@"
}

# view ASSET NAME [VIEWER OPTIONS...]
view() {
  local asset=$1 name=$2
  shift 2
  mkdir -p "$tmp/$name"
  run_x "$viewer" --server "$SERVE_GRPC" "$asset" --size 320x240 --capture "$tmp/$name" --stats "$tmp/$name.json" \
    --verify --exit-when-complete --idle-frames 5 --export "$tmp/$name.glb" "$@" >"$tmp/$name.out" 2>&1 ||
    fail "the viewer failed on $asset ($name): $(tail -5 "$tmp/$name.out")"
  cat "$tmp/$name.out"
}

check() {  # check NAME ASSET BUDGET_ZERO FILE_ORDER (1: no view was sent, the levels are the file's)
  python3 - "$tmp/$1.json" "$tmp/$2.decode.json" "$3" "$4" <<'PY' || fail "checks of $1 failed"
import json, sys
stats = json.load(open(sys.argv[1]))
decoded = json.load(open(sys.argv[2]))
budget_zero = sys.argv[3] == "1"
file_order = sys.argv[4] == "1"
errors = []
def expect(ok, what):
    if not ok:
        errors.append(what)
expect(stats["complete"], "the session did not complete")
expect(stats["verify"] and stats["verify_mismatches"] == 0,
       "GPU buffers differed from the views %d times" % stats["verify_mismatches"])
w, h = stats["size"]
level_vertices = decoded["level_vertices"]
levels = stats["levels"]
expect(len(levels) >= 2, "fewer than two levels shown")
expect(levels[0]["level"] == 0, "the first level shown is not the base")
expect(levels[-1]["level"] == decoded["levels"], "the last level is %d, not %d" % (levels[-1]["level"], decoded["levels"]))
for r in levels:
    L = r["level"]
    expect(r["drawn_vertices"] == r["sdk_vertices"], "level %d: %d vertices drawn, the SDK has %d" % (L, r["drawn_vertices"], r["sdk_vertices"]))
    expect(r["drawn_indices"] == r["sdk_indices"], "level %d: %d indices drawn, the SDK has %d" % (L, r["drawn_indices"], r["sdk_indices"]))
    if file_order or L == levels[-1]["level"]:
        expect(r["drawn_vertices"] == level_vertices[L], "level %d: %d vertices drawn, the file has %d" % (L, r["drawn_vertices"], level_vertices[L]))
    expect(r["nonblank_pixels"] >= 0.01 * w * h, "level %d: a blank frame (%d pixels drawn)" % (L, r["nonblank_pixels"]))
    if budget_zero:
        expect(r["frames"] == stats["primitives"], "level %d: uploaded in %d frames, not one per primitive (%d)" % (L, r["frames"], stats["primitives"]))
if budget_zero:
    expect(stats["most_primitives_in_a_frame"] == 1, "a frame with budget 0 uploaded %d primitives" % stats["most_primitives_in_a_frame"])
expect(stats["bytes_uploaded"] <= stats["reupload_bytes"], "uploaded %d bytes, more than re-uploading every level (%d)" % (stats["bytes_uploaded"], stats["reupload_bytes"]))
expect(stats["stream_us_max"] < 10e6, "a frame's stream step took %.0f us (a hang)" % stats["stream_us_max"])
print("%s: %d levels shown over %d frames; uploaded %.3f x the final buffers (re-uploading every level: %.3f x); "
      "stream step per frame: max %.0f us, p99 %.0f us against a budget of %d us (%d frames over)"
      % (stats["asset"], len(levels), stats["frames"], stats["upload_ratio"],
         stats["reupload_bytes"] / max(1, stats["final_buffer_bytes"]), stats["stream_us_max"], stats["stream_us_p99"],
         stats["budget_us"], stats["frames_over_budget"]))
if errors:
    print("\n".join(errors), file=sys.stderr)
    sys.exit(1)
PY
}

compare() {  # compare NAME
  local vp size
  vp=$(python3 -c 'import json,sys; print(",".join("%.9g" % x for x in json.load(open(sys.argv[1]))["view_projection"]))' "$tmp/$1.json")
  size=$(python3 -c 'import json,sys; print("%dx%d" % tuple(json.load(open(sys.argv[1]))["size"]))' "$tmp/$1.json")
  run_x "$reference" "$tmp/$1.glb" --size "$size" --view-projection "$vp" --out "$tmp/$1/reference.ppm" \
    --compare "$tmp/$1/final.ppm" --max-fraction 0.005 --channel-tolerance 8 >"$tmp/$1.compare" 2>&1 ||
    fail "the final frame of $1 is not the export's: $(cat "$tmp/$1.compare")"
  echo "$1: final frame against the export's: $(cat "$tmp/$1.compare")"
}

# The bunny is one primitive: a view changes nothing of its order.
view bunny bunny
check bunny bunny 0 1
compare bunny
# The engine with its camera sent as the view (the server orders its 34
# primitives by it: the levels between are not the file's), then without a
# view and with a budget of 0.
view engine engine
check engine engine 0 0
compare engine
view engine engine-budget0 --budget-us 0 --no-view
check engine-budget0 engine 1 0

# Predicted vertices, tinted: through a lossy relay.
"$relay_bin" --upstream "$SERVE_UDP" --loss 0.25 --seed 11 >"$tmp/relay.out" 2>&1 &
relay_pid=$!
relay_addr=""
for _ in $(seq 1 100); do  # a hang bound: the relay prints its address at once
  relay_addr=$(sed -n 's/^relay on //p' "$tmp/relay.out")
  [ -n "$relay_addr" ] && break
  kill -0 "$relay_pid" 2>/dev/null || fail "the relay exited: $(cat "$tmp/relay.out")"
  sleep 0.1
done
[ -n "$relay_addr" ] || fail "the relay printed no address"
view bunny lossy --udp-via "$relay_addr" --no-parity --tint
python3 - "$tmp/lossy.json" "$tmp/lossy/final.ppm" "$tmp/lossy/final-untinted.ppm" <<'PY' || fail "the tint check failed"
import json, sys
stats = json.load(open(sys.argv[1]))
def tinted(path):
    data = open(path, "rb").read()
    parts = data.split(b"\n", 3)
    pixels = parts[3]
    count = 0
    for i in range(0, len(pixels), 3):
        r, g, b = pixels[i], pixels[i + 1], pixels[i + 2]
        if r > 50 and r > 1.6 * g and r > 3 * b:
            count += 1
    return count
errors = []
if not stats["complete"]:
    errors.append("the lossy session did not complete")
if stats["verify_mismatches"] != 0:
    errors.append("GPU buffers differed from the views %d times" % stats["verify_mismatches"])
if stats["predicted_vertices"] == 0:
    errors.append("nothing predicted at 25 % loss without parity or repair")
on, off = tinted(sys.argv[2]), tinted(sys.argv[3])
print("lossy: %d predicted vertices; %d tinted pixels, %d untinted" % (stats["predicted_vertices"], on, off))
if on == 0:
    errors.append("no tinted pixel in the final frame with --tint")
if off != 0:
    errors.append("%d tinted pixels drawn without the tint" % off)
if errors:
    print("\n".join(errors), file=sys.stderr)
    sys.exit(1)
PY

if [ -n "${MESHSTREAM_TEST_SHOTS:-}" ]; then
  mkdir -p "$MESHSTREAM_TEST_SHOTS"
  for name in bunny engine lossy; do
    for f in "$tmp/$name"/*.ppm; do
      python3 "$here/ppm_to_png.py" "$f" "$MESHSTREAM_TEST_SHOTS/$name-$(basename "$f" .ppm).png" ||
        fail "cannot convert $f"
    done
  done
  echo "frames kept in $MESHSTREAM_TEST_SHOTS"
fi

serve_stop 15 || fail "the server did not stop"
echo "viewer_run.sh: all checks passed"
