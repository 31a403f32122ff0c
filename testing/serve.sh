# The `meshstream serve` fixture of the shell tests, benchmarks and the demo
# (the shell twin of testing/serve_process.h). Source it, then:
#
#   serve_start BIN DIR ARGS...  starts `BIN serve ARGS... --ready-file DIR/ready.json`,
#                                stdout in DIR/serve.out, stderr in DIR/serve.log;
#                                sets SERVE_PID
#   serve_ready [TIMEOUT_S]      waits (default 60 s) until the server wrote its ready
#                                file (every listener up); sets SERVE_GRPC, SERVE_UDP and
#                                SERVE_HTTP (empty when off). Non-zero, with the log's
#                                tail on stderr, when the server exited or time ran out
#   serve_stop [WAIT_S]          SIGTERM (a drain), then waits up to WAIT_S (default 15)
#                                for the exit; sets SERVE_STATUS (its exit status).
#                                Non-zero when it had to be killed
#   serve_kill                   SIGKILL if it still runs (for an EXIT trap)
#   serve_log [N]                the last N (default 60) lines of its log, on stderr
#
# Nothing is scraped from stdout: the ready file is written whole (a rename)
# once the server listens, so there is no race between a partial line and a
# reader.

SERVE_PID="" SERVE_DIR="" SERVE_GRPC="" SERVE_UDP="" SERVE_HTTP="" SERVE_STATUS=""

serve_start() {
  local bin=$1
  SERVE_DIR=$2
  shift 2
  mkdir -p "$SERVE_DIR"
  rm -f "$SERVE_DIR/ready.json"
  "$bin" serve "$@" --ready-file "$SERVE_DIR/ready.json" >"$SERVE_DIR/serve.out" 2>"$SERVE_DIR/serve.log" &
  SERVE_PID=$!
}

serve_log() {
  echo "--- server log (last ${1:-60} lines of $SERVE_DIR/serve.log) ---" >&2
  tail -n "${1:-60}" "$SERVE_DIR/serve.log" >&2 2>/dev/null
  echo "---" >&2
}

# The string value of KEY in the ready file ("" for null).
serve_field() {
  sed -n 's/.*"'"$1"'":"\([^"]*\)".*/\1/p' "$SERVE_DIR/ready.json"
}

serve_ready() {
  local timeout=${1:-60} start=$SECONDS
  until [ -s "$SERVE_DIR/ready.json" ]; do
    if ! kill -0 "$SERVE_PID" 2>/dev/null; then
      wait "$SERVE_PID"
      echo "serve: the server exited with status $? before it listened" >&2
      serve_log
      return 1
    fi
    if [ $((SECONDS - start)) -ge "$timeout" ]; then
      echo "serve: the server did not listen within ${timeout}s" >&2
      serve_log
      return 1
    fi
    sleep 0.05
  done
  SERVE_GRPC=$(serve_field grpc)
  SERVE_UDP=$(serve_field udp)
  SERVE_HTTP=$(serve_field http)
}

serve_stop() {
  local wait_s=${1:-15}
  SERVE_STATUS=""
  [ -n "$SERVE_PID" ] || return 0
  kill -TERM "$SERVE_PID" 2>/dev/null
  local i
  for i in $(seq $((wait_s * 10))); do
    if ! kill -0 "$SERVE_PID" 2>/dev/null; then
      wait "$SERVE_PID"
      SERVE_STATUS=$?
      SERVE_PID=""
      return 0
    fi
    sleep 0.1
  done
  echo "serve: the server was still running ${wait_s}s after SIGTERM; killed" >&2
  serve_kill
  return 1
}

serve_kill() {
  if [ -n "$SERVE_PID" ] && kill -0 "$SERVE_PID" 2>/dev/null; then
    kill -KILL "$SERVE_PID" 2>/dev/null
    wait "$SERVE_PID" 2>/dev/null
  fi
  SERVE_PID=""
}
