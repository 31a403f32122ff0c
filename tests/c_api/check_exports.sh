#!/bin/sh
# libmeshstream exports the C API and nothing else (docs/spec/c-api.md):
#   check_exports.sh LIBMESHSTREAM.so MESHSTREAM.H
# - every dynamic symbol the library defines is an ms_* function at version
#   MESHSTREAM_0 (besides the version node MESHSTREAM_0 itself);
# - those are exactly the MS_API functions the header declares;
# - the soname is libmeshstream.so.0.
# Exits 1 naming what is wrong.
set -eu
lib=$1
header=$2
status=0
fail() {
  echo "check_exports: $*" >&2
  status=1
}

defined=$(nm -D --defined-only "$lib" | awk '{ print $NF }' | sort)
[ -n "$defined" ] || fail "$lib: no dynamic symbols at all"
others=$(printf '%s\n' "$defined" | grep -Ev '^(MESHSTREAM_0|ms_[a-z0-9_]+@@MESHSTREAM_0)$' || true)
[ -z "$others" ] || fail "$lib exports symbols outside the C API:
$others"

exported=$(printf '%s\n' "$defined" | sed -n 's/@@MESHSTREAM_0$//p' | sort)
declared=$(sed -n 's/^MS_API [^(]*[ *]\(ms_[a-z0-9_]*\)(.*/\1/p' "$header" | sort)
[ -n "$declared" ] || fail "$header: no MS_API function found"
if [ "$exported" != "$declared" ]; then
  fail "the exported functions differ from the header's (< exported, > declared):
$(printf '%s\n' "$exported" >"${TMPDIR:-/tmp}/ms-exported.$$"; printf '%s\n' "$declared" | diff "${TMPDIR:-/tmp}/ms-exported.$$" - || true; rm -f "${TMPDIR:-/tmp}/ms-exported.$$")"
fi

soname=$(readelf -d "$lib" | sed -n 's/.*(SONAME).*\[\(.*\)\].*/\1/p')
[ "$soname" = "libmeshstream.so.0" ] || fail "$lib: soname '$soname', expected libmeshstream.so.0"

[ "$status" -eq 0 ] && echo "check_exports: $(printf '%s\n' "$exported" | wc -l) functions, all ms_*, all in the header; soname $soname"
exit "$status"
