#!/usr/bin/env bash
# Runs the independent Node client test against a real server:
#   starts `meshstream serve --listen 127.0.0.1:0 --store <temp dir>` (testing/serve.sh:
#   its address from the ready file),
#   waits until grpc.health.v1 says SERVING, runs asset_client.test.js, sends
#   SIGTERM and waits for the drain, removes the temp dir.
# Usage: tests/node/run.sh PATH/TO/meshstream MODELS_DIR
#   MESHSTREAM_TEST_MODEL   model to upload (default: MODELS_DIR/stanford-bunny.obj,
#                           which needs several 1 MiB chunks; else spot.obj)
#   MESHSTREAM_TEST_AUTH=1  serve with --auth and a token from `meshstream token create`
#   MESHSTREAM_TEST_STARTUP seconds to wait for SERVING (default 60)
# Exit: the node test's status; 1 as well when the server does not stop within
# its grace period after SIGTERM; 77 when node is not installed.
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
# shellcheck source=../../testing/serve.sh
. "$root/testing/serve.sh"

if [ $# -lt 2 ]; then
  echo "usage: $0 PATH/TO/meshstream MODELS_DIR" >&2
  exit 1
fi
if [ ! -x "$1" ]; then
  echo "run.sh: $1 is not an executable meshstream binary" >&2
  exit 1
fi
bin=$(realpath "$1")
models=$2
if ! command -v node >/dev/null 2>&1; then
  echo "skipped: node not found"
  exit 77
fi
if [ ! -f "$root/tools/node_modules/@grpc/grpc-js/package.json" ] || [ ! -f "$root/tools/node_modules/@grpc/proto-loader/package.json" ]; then
  echo "run.sh: @grpc/grpc-js and @grpc/proto-loader are not in tools/node_modules: run scripts/install-deps" >&2
  exit 1
fi

model=${MESHSTREAM_TEST_MODEL:-}
if [ -z "$model" ]; then
  for candidate in stanford-bunny.obj spot.obj; do
    if [ -f "$models/$candidate" ]; then model="$models/$candidate"; break; fi
  done
fi
if [ -z "$model" ] || [ ! -f "$model" ]; then
  echo "run.sh: no model to upload (MESHSTREAM_TEST_MODEL, or stanford-bunny.obj/spot.obj in '$models')" >&2
  exit 1
fi

# The server's settings come from this script alone: a MESHSTREAM_STORE,
# MESHSTREAM_AUTH, ... of the caller's environment would change what is tested.
for var in $(compgen -e | grep '^MESHSTREAM_' | grep -v '^MESHSTREAM_TEST_'); do
  unset "$var"
done

tmp=$(mktemp -d)
store="$tmp/store"
grace=10
cleanup() {
  serve_kill
  rm -rf "$tmp"
}
trap cleanup EXIT

args=(--listen 127.0.0.1:0 --store "$store" --grace-period "$grace")
if [ "${MESHSTREAM_TEST_AUTH:-0}" = 1 ]; then
  if ! out=$("$bin" token create --store "$store" --tenant node-test 2>"$tmp/token.err"); then
    echo "run.sh: meshstream token create failed: $(cat "$tmp/token.err")" >&2
    exit 1
  fi
  MESHSTREAM_TOKEN=$(tail -n 1 <<<"$out")
  export MESHSTREAM_TOKEN
  args+=(--auth)
fi

echo "run.sh: $bin serve ${args[*]}"
serve_start "$bin" "$tmp/server" "${args[@]}"
startup=${MESHSTREAM_TEST_STARTUP:-60}
start=$SECONDS
serve_ready "$startup" || exit 1
address=$SERVE_GRPC

# Healthy: grpc.health.v1 Check answers SERVING (health_check.js, 2 s per try).
until node "$here/health_check.js" "$address" >"$tmp/health.out" 2>&1; do
  if [ $((SECONDS - start)) -ge "$startup" ]; then
    echo "run.sh: the server was not SERVING after ${startup}s: $(cat "$tmp/health.out")" >&2
    serve_log
    exit 1
  fi
  sleep 0.5
done
echo "run.sh: server SERVING at $address after $((SECONDS - start))s; model $model"

MESHSTREAM_SERVER="$address" MESHSTREAM_TEST_MODEL="$model" node "$here/asset_client.test.js"
rc=$?

# SIGTERM drains; the server must be gone within its grace period (plus a margin).
stopped=1
serve_stop $((grace + 5)) || stopped=0
if [ $stopped -eq 1 ]; then
  echo "run.sh: the server stopped after SIGTERM (exit status $SERVE_STATUS)"
fi
if [ $rc -ne 0 ] || [ $stopped -eq 0 ]; then serve_log; fi
if [ $rc -ne 0 ]; then exit $rc; fi
[ $stopped -eq 1 ] || exit 1
exit 0
