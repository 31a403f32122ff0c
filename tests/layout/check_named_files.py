#!/usr/bin/env python3
"""Checks that every file docs/architecture.md and the folder READMEs name exists.

A name is a relative markdown link (resolved from the page's folder), which
must exist, or a backticked path with a file extension
(`progressive/split_bits.h`, `bench/plot.py`), which must be the end of some
path in the tree or under /usr/include (tables name files relative to their
section's folder, so a name is not tied to one folder: a file that moved
still passes, a file that exists nowhere fails). Every such name is
checked: a wildcard (`*_test.cc`) is not one (the pattern takes no `*`).

usage: check_named_files.py [ROOT]
"""
import os
import re
import sys

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", ".."))
PAGES = ["docs/architecture.md", "docs/README.md"]
for top in sorted(os.listdir(ROOT)):
    if top.startswith((".", "build")) or top == "node_modules":
        continue
    readme = os.path.join(top, "README.md")
    if os.path.isfile(os.path.join(ROOT, readme)):
        PAGES.append(readme)
PAGES.append("README.md")

EXTENSIONS = ("h", "cc", "c", "py", "md", "js", "mjs", "sh", "proto", "map", "txt", "json", "yaml", "html")
BACKTICK = re.compile(r"`([A-Za-z0-9_./-]+\.(?:%s))`" % "|".join(EXTENSIONS))
LINK = re.compile(r"\]\(([^)\s#]+)(?:#[^)]*)?\)")


def exists(candidates):
    return any(os.path.exists(os.path.join(ROOT, c)) for c in candidates)


def tree_paths():
    paths = set()
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if not d.startswith((".", "build")) and d not in ("node_modules", "corpus", "__pycache__")]
        rel = os.path.relpath(folder, ROOT)
        for f in files:
            paths.add("/" + (f if rel == "." else rel + "/" + f))
    return paths


PATHS = tree_paths()


def in_tree(name):
    suffix = "/" + name.lstrip("./")
    # A third-party header the page names (`tiny_gltf.h`) is the system's.
    return any(p.endswith(suffix) for p in PATHS) or os.path.exists("/usr/include" + suffix)


def main():
    errors = []
    checked = 0
    for page in PAGES:
        path = os.path.join(ROOT, page)
        if not os.path.isfile(path):
            continue
        page_dir = os.path.dirname(page)
        in_code = False
        for number, line in enumerate(open(path, encoding="utf-8"), 1):
            if line.startswith("```"):
                in_code = not in_code
                continue
            if in_code:
                continue
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target) or target.startswith("/"):
                    continue
                checked += 1
                if not exists([os.path.normpath(os.path.join(page_dir, target))]):
                    errors.append(f"{page}:{number}: link to {target}, which does not exist")
            for name in BACKTICK.findall(line):
                checked += 1
                if not in_tree(name):
                    errors.append(f"{page}:{number}: names `{name}`, which does not exist")
    for e in errors:
        print(e)
    print(f"named files: {checked} names checked in {len(PAGES)} pages, {len(errors)} missing")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
