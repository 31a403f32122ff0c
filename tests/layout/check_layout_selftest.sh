#!/usr/bin/env bash
# check_layout.py must refuse, in a copy of this tree's services/CMakeLists.txt
# and sources, a layer whose LAYERS differ from the architecture, a client
# verb of cli/ that includes the store, and a services/ folder that includes
# one above it; and pass the unchanged copy (a throwaway tree, no timing).
set -u
root=$(cd "$(dirname "$0")/../.." && pwd)
script=$root/tests/layout/check_layout.py
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
copy() {
  rm -rf "$tmp/tree" && mkdir -p "$tmp/tree"
  (cd "$root" && git ls-files -z -- codec importers parallel fec net proto services sdk cli web testing bench experiments |
    xargs -0 cp --parents -t "$tmp/tree")
}
copy
python3 "$script" "$tmp/tree" >/dev/null || { echo "FAIL: the unchanged tree was refused"; exit 1; }

sed -i 's/meshstream_service_layer(export LAYERS pipeline)/meshstream_service_layer(export LAYERS pipeline store)/' \
  "$tmp/tree/services/CMakeLists.txt"
if python3 "$script" "$tmp/tree" >/dev/null; then echo "FAIL: a layer linking a folder the architecture does not draw passed"; exit 1; fi

copy
printf '#include "services/store/store.h"\n' >>"$tmp/tree/cli/cmd_versions.cc"
if python3 "$script" "$tmp/tree" >/dev/null; then echo "FAIL: a client verb including the store passed"; exit 1; fi

copy
printf '#include "services/streaming/session_host.h"\n' >>"$tmp/tree/services/http/url.cc"
if python3 "$script" "$tmp/tree" >/dev/null; then echo "FAIL: http/ machinery including streaming/ passed"; exit 1; fi
echo "ok: check_layout refuses a wrong layer target, a client verb on the store and an upward include"
