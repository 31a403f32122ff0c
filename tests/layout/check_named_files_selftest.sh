#!/usr/bin/env bash
# check_named_files.py must fail on a page that names a missing file or links
# a missing page, and pass once they exist (a throwaway tree, no timing).
set -u
script=$(dirname "$0")/check_named_files.py
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/docs" "$tmp/lib"
printf '# x\n| `lib/present.h` | here |\n' >"$tmp/docs/architecture.md"
touch "$tmp/lib/present.h"
python3 "$script" "$tmp" >/dev/null || { echo "FAIL: a tree naming only existing files was refused"; exit 1; }
printf '| `lib/missing_file_xyz.h` | gone |\n' >>"$tmp/docs/architecture.md"
if python3 "$script" "$tmp" >/dev/null; then echo "FAIL: a missing file passed"; exit 1; fi
touch "$tmp/lib/missing_file_xyz.h"
printf 'see [the page](nowhere.md)\n' >>"$tmp/docs/architecture.md"
if python3 "$script" "$tmp" >/dev/null; then echo "FAIL: a broken link passed"; exit 1; fi
echo "ok: check_named_files refuses a missing name and a broken link"
