#!/usr/bin/env bash
# `meshstream fetch` shows its progress on a terminal and nothing otherwise
# (docs/spec/cli.md, fetch): against a real `meshstream serve` (a temporary
# store, the bunny ingested with `meshstream ingest --wait`), the fetch runs
#   - under a pseudo-terminal (util-linux `script`): its output holds the
#     progress line (a level, megabytes, a rate);
#   - with stderr to a file: that file stays empty;
#   - under a pseudo-terminal with --json: no progress line, the JSON only.
# Usage: tests/cli/fetch_progress.sh PATH/TO/meshstream MODELS_DIR
# Exit: non-zero, saying which check failed, when one does.
set -uo pipefail

here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=../../testing/serve.sh
. "$here/../../testing/serve.sh"
if [ $# -lt 2 ]; then
  echo "usage: $0 PATH/TO/meshstream MODELS_DIR" >&2
  exit 1
fi
bin=$(realpath "$1")
models=$2
if ! command -v script >/dev/null 2>&1; then
  echo "fetch_progress.sh: util-linux's script is missing (scripts/install-deps installs bsdutils)" >&2
  exit 1
fi
for var in $(compgen -e | grep '^MESHSTREAM_' | grep -v '^MESHSTREAM_TEST_'); do
  unset "$var"
done
tmp=$(mktemp -d)
cleanup() {
  serve_kill
  rm -rf "$tmp"
}
trap cleanup EXIT
fail() {
  echo "fetch_progress.sh: $*" >&2
  serve_log 30
  exit 1
}

serve_start "$bin" "$tmp/server" --listen 127.0.0.1:0 --udp-listen off --store "$tmp/store" --workers 1
serve_ready 60 || exit 1
"$bin" ingest "$models/stanford-bunny.obj" --asset bunny --server "$SERVE_GRPC" --wait >"$tmp/ingest.out" 2>&1 ||
  fail "ingest failed: $(cat "$tmp/ingest.out")"

fetch=("$bin" fetch bunny --server "$SERVE_GRPC" --tcp-only)
# 1. A terminal: the progress line.
script -qec "$(printf '%q ' "${fetch[@]}" -o "$tmp/a.glb")" /dev/null >"$tmp/tty.out" 2>&1 ||
  fail "fetch under a terminal failed: $(cat "$tmp/tty.out")"
grep -q "level [0-9]* of [0-9]*, [0-9.]* MB, [0-9.]* Mbit/s" "$tmp/tty.out" ||
  fail "no progress line on a terminal: $(tr '\r' '\n' <"$tmp/tty.out" | head -5)"
# 2. Not a terminal: stderr stays empty.
"${fetch[@]}" -o "$tmp/b.glb" >"$tmp/plain.out" 2>"$tmp/plain.err" || fail "fetch failed: $(cat "$tmp/plain.err")"
[ ! -s "$tmp/plain.err" ] || fail "stderr is not a terminal, yet fetch wrote to it: $(head -c 300 "$tmp/plain.err")"
grep -q "bunny -> " "$tmp/plain.out" || fail "no summary line on stdout: $(cat "$tmp/plain.out")"
# 3. A terminal with --json: the JSON alone.
script -qec "$(printf '%q ' "${fetch[@]}" -o "$tmp/c.glb" --json)" /dev/null >"$tmp/json.out" 2>&1 ||
  fail "fetch --json under a terminal failed: $(cat "$tmp/json.out")"
if grep -q "Mbit/s" "$tmp/json.out"; then fail "a progress line with --json: $(head -c 300 "$tmp/json.out")"; fi
grep -q '"levels_applied"' "$tmp/json.out" || fail "no JSON with --json: $(head -c 300 "$tmp/json.out")"
serve_stop 15 || fail "the server did not stop"
echo "fetch_progress.sh: passed"
