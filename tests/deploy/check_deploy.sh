#!/usr/bin/env bash
# Checks the files of deploy/ without a container engine or a running systemd:
#   1. meshstream.service: `systemd-analyze verify` (on a copy whose ExecStart is
#      the built binary given as $1), with the commented TLS lines switched on
#      too; no warning allowed; `systemd-analyze security` exposure at most
#      MAX_EXPOSURE; TimeoutStopSec longer than --grace-period.
#   2. Containerfile, nginx.Containerfile: every package they apt-get install is
#      known to `apt-cache policy`; the runtime stage's packages (with their
#      dependencies) provide every shared library that $1 links; the build
#      stage copies every folder the top-level CMakeLists.txt adds.
#   3. compose.yaml parses and holds together (check_compose.js); nginx.conf
#      and nginx-cache.conf pass `nginx -t` where nginx is installed.
# Usage: tests/deploy/check_deploy.sh BUILD/bin/meshstream
# Exit: 0 all checked and good; 1 a check failed; 77 ("skipped: <reason>") when
# a tool that a check needs is absent (after running every check it could).
set -uo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
deploy="$root/deploy"
MAX_EXPOSURE=${MAX_EXPOSURE:-2.0}

binary=${1:-}
if [ -z "$binary" ] || [ ! -x "$binary" ]; then
  echo "usage: $0 PATH/TO/meshstream (a built binary; got '${binary}')" >&2
  exit 1
fi
binary=$(realpath "$binary")

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

failures=0
skipped=()
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
ok() { echo "ok: $*"; }
skip() { echo "skip: $*"; skipped+=("$*"); }

# --- 1. the systemd unit -----------------------------------------------------
unit="$deploy/meshstream.service"
grace=$(sed -n 's/^ExecStart=.*--grace-period[ =]\([0-9][0-9]*\).*/\1/p' "$unit")
stop=$(sed -n 's/^TimeoutStopSec=\([0-9][0-9]*\)s\{0,1\}$/\1/p' "$unit")
if [ -z "$grace" ] || [ -z "$stop" ]; then
  fail "meshstream.service: ExecStart needs --grace-period N and TimeoutStopSec=N (seconds) next to it"
elif [ "$stop" -le "$grace" ]; then
  fail "meshstream.service: TimeoutStopSec=$stop is not longer than --grace-period $grace"
else
  ok "meshstream.service: TimeoutStopSec=$stop > grace period $grace"
fi

if command -v systemd-analyze >/dev/null 2>&1; then
  mkdir -p "$tmp/plain" "$tmp/tls"
  sed "s|/usr/local/bin/meshstream|$binary|g" "$unit" > "$tmp/plain/meshstream.service"
  # The same unit with the TLS block uncommented (LoadCredential + %d paths).
  sed -e 's/^#\(LoadCredential=\)/\1/' -e 's/^#\(Environment=MESHSTREAM_TLS_\)/\1/' \
    "$tmp/plain/meshstream.service" > "$tmp/tls/meshstream.service"
  for variant in plain tls; do
    # verify exits 0 on unknown keys and bad values: any output is a failure.
    out=$(systemd-analyze verify "$tmp/$variant/meshstream.service" 2>&1)
    rc=$?
    if [ $rc -ne 0 ] || [ -n "$out" ]; then
      fail "systemd-analyze verify meshstream.service ($variant, exit $rc):"
      printf '%s\n' "$out" | sed 's/^/    /'
    else
      ok "systemd-analyze verify meshstream.service ($variant)"
    fi
  done
  if out=$(systemd-analyze security --offline=yes "$tmp/plain/meshstream.service" 2>&1); then
    level=$(printf '%s\n' "$out" | sed -n 's/.*Overall exposure level for [^:]*: \([0-9.]*\).*/\1/p')
    if [ -z "$level" ]; then
      fail "systemd-analyze security printed no exposure level"
    elif awk -v l="$level" -v m="$MAX_EXPOSURE" 'BEGIN { exit !(l <= m) }'; then
      ok "systemd-analyze security: exposure $level <= $MAX_EXPOSURE"
    else
      fail "systemd-analyze security: exposure $level > $MAX_EXPOSURE (a hardening line was lost?)"
      printf '%s\n' "$out" | grep '✗' | sed 's/^/    /'
    fi
  else
    # --offline arrived in systemd 250; older ones cannot rate a unit file.
    skip "systemd-analyze security --offline not supported by $(systemd-analyze --version | head -n1)"
  fi
else
  skip "systemd-analyze not found (package systemd), meshstream.service not verified"
fi

# --- 2. the Containerfiles -----------------------------------------------------
# Package names of every `apt-get install` of a Containerfile, one per line;
# with STAGE=last only those of the last FROM stage.
apt_packages() {
  local file=$1 stage=${2:-all}
  # Join continuation lines, keep RUN lines (of the last stage if asked), cut
  # at each "apt-get install", take the words up to the next shell operator.
  sed -e ':a' -e '/\\$/N; s/\\\n/ /; ta' "$file" |
    awk -v stage="$stage" '
      /^FROM / { n++; delete runs; k = 0 }
      /^RUN / { runs[++k] = $0; all[++a] = $0 }
      END {
        if (stage == "last") { for (i = 1; i <= k; i++) print runs[i] }
        else { for (i = 1; i <= a; i++) print all[i] }
      }' |
    grep -o 'apt-get install[^&|;]*' |
    sed 's/apt-get install//' | tr ' ' '\n' | grep -v '^-' | grep -v '^$' || true
}

if command -v apt-cache >/dev/null 2>&1 && command -v dpkg >/dev/null 2>&1; then
  # (Outputs are captured before grep -q reads them: with pipefail, grep -q
  # closing a pipe early would make the writer's SIGPIPE look like a failure.)
  if ! grep -q 'Candidate: [0-9]' <<<"$(apt-cache policy bash 2>/dev/null)"; then
    fail "apt-cache knows no packages (empty lists): run 'apt-get update' first"
  else
    for cf in Containerfile nginx.Containerfile; do
      pkgs=$(apt_packages "$deploy/$cf")
      if [ -z "$pkgs" ]; then
        fail "$cf: found no apt-get install"
        continue
      fi
      unknown=()
      for p in $pkgs; do
        if ! grep -q 'Candidate: [^(]' <<<"$(apt-cache policy "$p" 2>/dev/null)"; then unknown+=("$p"); fi
      done
      if [ ${#unknown[@]} -gt 0 ]; then
        fail "$cf: apt-cache policy knows no candidate for: ${unknown[*]}"
      else
        ok "$cf: all $(echo "$pkgs" | wc -l) packages known to apt-cache"
      fi
    done

    # The runtime stage, with its dependencies, provides every library the binary links.
    runtime=$(apt_packages "$deploy/Containerfile" last)
    closure=$(apt-cache depends --recurse --no-recommends --no-suggests --no-conflicts \
                --no-breaks --no-replaces --no-enhances $runtime 2>/dev/null |
              grep -v '^ ' | sed 's/:.*//' | sort -u)
    # libc6 and the rest of the base image (debian:bookworm-slim) are there anyway.
    closure=$(printf '%s\nlibc6\nlibgcc-s1\nlibstdc++6\nzlib1g\n' "$closure" | sort -u)
    # "package:library" for each library the runtime stage does not provide
    # ("none:library" when no Debian package owns it).
    lacking=()
    while read -r lib; do
      [ -n "$lib" ] || continue
      owner=""
      real=$(realpath "$lib")
      for candidate in "$lib" "$real" "/usr${lib#/usr}" "${lib#/usr}" "/usr${real#/usr}" "${real#/usr}"; do
        owner=$(dpkg -S "$candidate" 2>/dev/null | head -n1 | sed 's/:.*//') && [ -n "$owner" ] && break
      done
      if [ -z "$owner" ]; then
        lacking+=("none:$(basename "$lib")")
      elif ! grep -qx "$owner" <<<"$closure"; then
        lacking+=("$owner:$(basename "$lib")")
      fi
    done < <(ldd "$binary" | awk '/=> \// { print $3 }')
    unresolved=$(ldd "$binary" | grep 'not found')
    if [ -n "$unresolved" ]; then
      fail "$binary has unresolved libraries here: $(tr -s ' \t\n' ' ' <<<"$unresolved")"
    elif [ ${#lacking[@]} -gt 0 ]; then
      # One line: the packages to add (the first ones listed usually pull in the rest).
      fail "Containerfile: the runtime stage lacks what $(basename "$binary") links (package:library): ${lacking[*]}"
    else
      ok "Containerfile: the runtime stage provides every library $(basename "$binary") links"
    fi
  fi
else
  skip "apt-cache/dpkg not found (not a Debian machine), Containerfile packages not checked"
fi

# The build stage copies every folder that the top-level CMakeLists.txt adds.
missing_copy=()
for dir in $(sed -n 's/^[[:space:]]*add_subdirectory(\([^ )]*\).*/\1/p' "$root/CMakeLists.txt" | sort -u); do
  grep -q "^COPY $dir/ $dir/" "$deploy/Containerfile" || missing_copy+=("$dir")
done
if [ ${#missing_copy[@]} -gt 0 ]; then
  fail "Containerfile: CMakeLists.txt adds folders the build stage does not COPY: ${missing_copy[*]}"
else
  ok "Containerfile: copies every folder of CMakeLists.txt"
fi
for want in '^ENTRYPOINT \["/usr/local/bin/meshstream", "serve", "--listen", "0.0.0.0:7600", "--auth"\]' \
            '^USER [1-9]' '^VOLUME /var/lib/meshstream$' '^EXPOSE 7600$' '^FROM docker.io/library/debian:bookworm'; do
  grep -q "$want" "$deploy/Containerfile" || fail "Containerfile: no line matching $want"
done

# --- 3. compose.yaml and nginx.conf --------------------------------------------
if command -v node >/dev/null 2>&1 && [ -f "$root/tools/node_modules/js-yaml/package.json" ]; then
  if out=$(node "$root/tests/deploy/check_compose.js" "$root" 2>&1); then
    ok "compose.yaml parses and holds together (check_compose.js)"
  else
    fail "compose.yaml:"
    printf '%s\n' "$out" | sed 's/^/    /'
  fi
elif python3 -c 'import yaml' 2>/dev/null; then
  # Parse only; the cross-checks need check_compose.js (scripts/install-deps).
  if out=$(python3 -c 'import sys, yaml; d = yaml.safe_load(open(sys.argv[1])); assert isinstance(d.get("services"), dict), "no services"' \
             "$deploy/compose.yaml" 2>&1); then
    skip "compose.yaml parses (python3 yaml), but js-yaml is missing: run scripts/install-deps for the full check"
  else
    fail "compose.yaml does not parse: $out"
  fi
else
  skip "no YAML parser (node with tools/node_modules/js-yaml, or python3 yaml): compose.yaml not parsed"
fi

if command -v nginx >/dev/null 2>&1; then
  # The service names resolve only inside compose: check the rest on loopback.
  sed 's/server meshstream-\([0-9]*\):7600/server 127.0.0.\1:7600/' "$deploy/nginx.conf" > "$tmp/nginx.conf"
  if out=$(nginx -t -q -c "$tmp/nginx.conf" -g "pid $tmp/nginx.pid;" 2>&1); then
    ok "nginx -t deploy/nginx.conf ($(nginx -v 2>&1 | sed 's/.*: //'))"
  else
    fail "nginx -t deploy/nginx.conf:"
    printf '%s\n' "$out" | sed 's/^/    /'
  fi
  # The caching example of docs/design/deploy.md ("Behind a CDN or cache"), its cache in $tmp.
  sed -e 's/server meshstream-\([0-9]*\):7680/server 127.0.0.\1:7680/' \
      -e "s|/var/cache/nginx/meshstream|$tmp/nginx-cache|" "$deploy/nginx-cache.conf" > "$tmp/nginx-cache.conf"
  if out=$(nginx -t -q -c "$tmp/nginx-cache.conf" -g "pid $tmp/nginx-cache.pid;" 2>&1); then
    ok "nginx -t deploy/nginx-cache.conf"
  else
    fail "nginx -t deploy/nginx-cache.conf:"
    printf '%s\n' "$out" | sed 's/^/    /'
  fi
else
  # Optional: no project script installs nginx, so its absence is not a skip.
  echo "note: nginx not installed, nginx.conf and nginx-cache.conf not checked (apt-get install nginx)"
fi

# -------------------------------------------------------------------------------
if [ $failures -gt 0 ]; then
  echo "check_deploy: $failures check(s) failed"
  exit 1
fi
if [ ${#skipped[@]} -gt 0 ]; then
  echo "skipped: ${skipped[*]}"
  exit 77
fi
echo "check_deploy: all checks passed"
exit 0
