#!/usr/bin/env bash
# make bench-viewer (docs/results/viewer-benchmarks.md): the native viewer
# (examples/viewer) under Xvfb with Mesa's software renderer, streaming the
# bunny and the horse from `meshstream serve` on loopback, each session's UDP
# paced at --rate Mbit/s (default 1: the refinement then spans a few dozen
# frames, as on a slow link; at loopback speed it arrives within two frames).
# Per model, two ways to show the levels: every level as it arrives
# (--min-update-ms 0) and at most four updates a second (--min-update-ms 250);
# --runs sessions each. The reference is measured in the same run: the frame
# time of the same viewer idle after COMPLETE (--idle-frames), and the bytes
# that uploading every level's whole mesh would take (reupload_bytes).
# usage: bench/viewer/run.sh MESHSTREAM VIEWER MODELS_DIR OUT_JSON
#        [--runs N] [--rate MBIT] [--size WxH] [--idle-frames N] [--budget-us N]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../../testing/serve.sh
. "$here/../../testing/serve.sh"
if [ $# -lt 4 ]; then
  sed -n '2,14p' "$0" >&2
  exit 2
fi
bin=$(realpath "$1") viewer=$(realpath "$2") models=$3 out=$4
shift 4
runs=3 rate=1 size=640x480 idle=120 budget=2000
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --idle-frames) idle=$2; shift 2 ;;
    --budget-us) budget=$2; shift 2 ;;
    *) echo "bench-viewer: unknown option $1" >&2; exit 2 ;;
  esac
done
command -v xvfb-run >/dev/null || { echo "bench-viewer: xvfb-run is missing (scripts/install-deps)" >&2; exit 1; }
for var in $(compgen -e | grep '^MESHSTREAM_' || true); do unset "$var"; done
tmp=$(mktemp -d)
cleanup() {
  serve_stop || true
  rm -rf "$tmp"
}
trap cleanup EXIT
serve_start "$bin" "$tmp/server" --listen 127.0.0.1:0 --udp-listen 127.0.0.1:0 --store "$tmp/store" --workers 1 \
  --max-session-rate "$rate"
serve_ready 60
for m in stanford-bunny.obj horse.ply; do
  "$bin" ingest "$models/$m" --asset "$(basename "${m%.*}")" --wait --server "$SERVE_GRPC" >/dev/null
done
results=()
for asset in stanford-bunny horse; do
  for update in 0 250; do
    for run in $(seq 1 "$runs"); do
      stats="$tmp/$asset-$update-$run.json"
      echo "bench-viewer: $asset, --min-update-ms $update, run $run of $runs" >&2
      LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s "-screen 0 1280x1024x24" "$viewer" --server "$SERVE_GRPC" "$asset" \
        --size "$size" --budget-us "$budget" --min-update-ms "$update" --idle-frames "$idle" --exit-when-complete \
        --stats "$stats" >/dev/null 2>"$tmp/viewer.err" || { cat "$tmp/viewer.err" >&2; exit 1; }
      results+=("$stats")
    done
  done
done
python3 "$here/summarize.py" --rate "$rate" --size "$size" --out "$out" "${results[@]}"
