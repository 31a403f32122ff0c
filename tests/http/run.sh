#!/usr/bin/env bash
# The HTTP routes of `meshstream serve` seen by a real client (docs/spec/http-api.md):
#   starts `meshstream serve --listen 127.0.0.1:0 --http-listen 127.0.0.1:0`
#   on a temporary store with a temporary web root (index.html, app.js, a
#   symbolic link that points out of the root) and --http-cors-origin
#   http://allowed.example; ingests a shared model twice with `meshstream
#   ingest --wait` (versions 1 and 2, READY); exports every format with
#   `meshstream export` (the reference bytes); runs http_api.test.js (node's
#   http and net modules, no npm package); sends SIGTERM and waits for the
#   drain.
# Usage: tests/http/run.sh PATH/TO/meshstream MODELS_DIR
#   MESHSTREAM_TEST_AUTH=1  serve with --auth: tokens of two tenants from
#                           `meshstream token create`, the asset in the first
#   MESHSTREAM_TEST_MODEL   model to ingest (default MODELS_DIR/spot.obj)
#   MESHSTREAM_TEST_STARTUP seconds to wait for the server (default 60)
# Exit: the node test's status; 1 as well when the server does not stop within
# its grace period after SIGTERM, or when a step before the test fails (the
# server's log is shown then).
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../../testing/serve.sh
. "$here/../../testing/serve.sh"

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
  echo "run.sh: node is not installed (scripts/install-deps)" >&2
  exit 1
fi
model=${MESHSTREAM_TEST_MODEL:-$models/spot.obj}
if [ ! -f "$model" ]; then
  echo "run.sh: no model to ingest: '$model' (MESHSTREAM_TEST_MODEL, or spot.obj in MODELS_DIR)" >&2
  exit 1
fi

# The server's settings come from this script alone.
for var in $(compgen -e | grep '^MESHSTREAM_' | grep -v '^MESHSTREAM_TEST_'); do
  unset "$var"
done

tmp=$(mktemp -d)
store="$tmp/store"
web="$tmp/web"
exports="$tmp/exports"
grace=10
cleanup() {
  serve_kill
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "run.sh: $*" >&2
  serve_log 80
  exit 1
}

# The web root: two files, and what must never be served from it: a secret
# beside the root and a symbolic link in the root that points at it.
mkdir -p "$web/js" "$exports"
printf '<!doctype html><title>meshstream test viewer</title>\n' >"$web/index.html"
printf 'export const answer = 42;\n' >"$web/js/app.js"
printf 'SECRET-OUTSIDE-THE-WEB-ROOT\n' >"$tmp/secret.txt"
ln -s "$tmp/secret.txt" "$web/escape.txt"
ln -s "$tmp" "$web/up"

args=(--listen 127.0.0.1:0 --http-listen 127.0.0.1:0 --store "$store" --grace-period "$grace"
      --http-root "$web" --http-cors-origin http://allowed.example)
remote=()
if [ "${MESHSTREAM_TEST_AUTH:-0}" = 1 ]; then
  token_a=$("$bin" token create --store "$store" --tenant http-a 2>"$tmp/token.err" | tail -n 1) ||
    fail "meshstream token create failed: $(cat "$tmp/token.err")"
  token_b=$("$bin" token create --store "$store" --tenant http-b 2>"$tmp/token.err" | tail -n 1) ||
    fail "meshstream token create failed: $(cat "$tmp/token.err")"
  export MESHSTREAM_TEST_TOKEN_A="$token_a" MESHSTREAM_TEST_TOKEN_B="$token_b"
  remote=(--token "$token_a")
  args+=(--auth)
fi

echo "run.sh: $bin serve ${args[*]}"
serve_start "$bin" "$tmp/server" "${args[@]}"

# Ready: the ready file names both addresses, and /v1/health answers 200.
startup=${MESHSTREAM_TEST_STARTUP:-60}
start=$SECONDS
serve_ready "$startup" || exit 1
grpc=$SERVE_GRPC http=$SERVE_HTTP
[ -n "$http" ] || fail "the ready file names no HTTP address"
health='require("http").get("http://'"$http"'/v1/health", r => process.exit(r.statusCode === 200 ? 0 : 1)).on("error", () => process.exit(1))'
until node -e "$health"; do
  kill -0 "$SERVE_PID" 2>/dev/null || fail "the server exited before /v1/health answered"
  [ $((SECONDS - start)) -lt "$startup" ] || fail "/v1/health did not answer 200 after ${startup}s"
  sleep 0.2
done
echo "run.sh: gRPC on $grpc, HTTP on $http after $((SECONDS - start))s; model $model"

# Two versions of one asset, READY; then the reference bytes of every format.
for version in 1 2; do
  "$bin" ingest "$model" --asset spot --server "$grpc" "${remote[@]}" --wait >"$tmp/ingest.out" 2>&1 ||
    fail "meshstream ingest (version $version) failed: $(cat "$tmp/ingest.out")"
done
for format in glb draco progressive obj ply; do
  "$bin" export spot@1 -o "$exports/v1.$format" --format "$format" --server "$grpc" "${remote[@]}" \
    >"$tmp/export.out" 2>&1 || fail "meshstream export spot@1 --format $format failed: $(cat "$tmp/export.out")"
done
"$bin" export spot -o "$exports/latest.glb" --format glb --server "$grpc" "${remote[@]}" >"$tmp/export.out" 2>&1 ||
  fail "meshstream export spot failed: $(cat "$tmp/export.out")"
"$bin" export spot@1 -o "$exports/v1-lod0.glb" --format glb --lod 0 --server "$grpc" "${remote[@]}" \
  >"$tmp/export.out" 2>&1 || fail "meshstream export spot@1 --lod 0 failed: $(cat "$tmp/export.out")"

MESHSTREAM_TEST_HTTP="$http" MESHSTREAM_TEST_EXPORTS="$exports" MESHSTREAM_TEST_WEB="$web" \
  MESHSTREAM_TEST_SECRET="$tmp/secret.txt" node --test-reporter=spec "$here/http_api.test.js"
rc=$?

# Still alive after everything the test sent.
kill -0 "$SERVE_PID" 2>/dev/null || { echo "run.sh: the server died during the test" >&2; rc=1; }

# SIGTERM drains; the server must be gone within its grace period (plus a margin).
stopped=1
serve_stop $((grace + 5)) || stopped=0
if [ $stopped -eq 1 ]; then
  echo "run.sh: the server stopped after SIGTERM (exit status $SERVE_STATUS)"
  [ "$SERVE_STATUS" -eq 0 ] || { echo "run.sh: exit status $SERVE_STATUS after SIGTERM (expected 0)" >&2; rc=1; }
fi

if [ $rc -ne 0 ] || [ $stopped -eq 0 ]; then serve_log 80; fi
if [ $rc -ne 0 ]; then exit $rc; fi
[ $stopped -eq 1 ] || exit 1
exit 0
