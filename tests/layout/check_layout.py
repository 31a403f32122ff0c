#!/usr/bin/env python3
"""Checks that every #include points the way docs/architecture.md draws it.

- codec/ includes only the C++ standard library (none of its files, clocks
  or threads) and codec/ itself, and its
  folders depend on each other in one direction (CODEC_DEPENDS below, the
  order docs/architecture.md writes down; what a folder may use includes what
  its dependencies may use);
- importers/ uses codec/ and third-party libraries, never parallel/,
  services/, sdk/, cli/, bench/, tests/ or testing/;
- parallel/ (threads for the codec's TaskRunner) uses codec/ only;
- fec/ (the codec's erasure code on ISA-L) uses codec/ only;
- net/ uses codec/ and third-party libraries, never services/, sdk/, cli/,
  bench/, tests/ or testing/;
- services/ and sdk/ never include cli/, bench/, tests/ or testing/; sdk/
  never includes services/;
- proto/ (the generated API and meshstream_common, the rules of the API's
  values) uses codec/, importers/ and the generated code only;
- cli/ never includes bench/, tests/ or testing/: no part of the product
  (codec/, importers/, net/, services/, sdk/, cli/) uses testing/; of cli/,
  only the verbs that run the server or work on its store (CLI_SERVER_FILES)
  include services/;
- web/ (the decoder's C ABI for WebAssembly) uses codec/ only;
- testing/ (what tests/ and bench/ share) never includes cli/, bench/ or
  tests/; bench/ never includes tests/; the folders of services/ depend on
  each other in one direction too (SERVICES_DEPENDS, as docs/architecture.md
  writes it), and services/CMakeLists.txt builds one library per folder
  linking exactly those folders (meshstream_service_layer's LAYERS).
Exits 1 naming every include that points the wrong way.
"""
import os
import re
import sys

CODEC_DEPENDS = {
    "core": [],
    "mesh": ["core"],
    "metrics": ["mesh"],
    "entropy": ["core"],
    "progressive": ["mesh", "entropy"],
    "recovery": ["progressive"],
    "bitstream": ["recovery"],
    "loss": ["bitstream", "metrics"],
}
SERVICES_DEPENDS = {
    "store": [],
    "auth": ["store"],
    "pipeline": ["store"],
    "jobs": ["pipeline"],
    "ingest": ["auth", "pipeline"],
    "export": ["pipeline"],
    # The session host and what every transport shares (auth: the host admits).
    "streaming": ["pipeline", "auth"],
    # HTTP/1.1 and WebSocket machinery on Boost.Beast: no route, no library call.
    "http": [],
    # The two transports of the API, siblings on the same library calls:
    # gRPC (grpc/) and HTTP's routes with the WebSocket sessions (http_routes/).
    "grpc": ["ingest", "export", "streaming"],
    "http_routes": ["http", "auth", "export", "streaming"],
    "server": ["grpc", "jobs", "http_routes"],
}
# The CLI's verbs that run the server or work on its store directly; every
# other file of cli/ is a client and uses the API's rules from proto/, never
# services/.
CLI_SERVER_FILES = {"cli/cmd_serve.cc", "cli/cmd_token.cc"}
FOLDER_DEPENDS = {"codec": CODEC_DEPENDS, "services": SERVICES_DEPENDS}
LAYER_FORBIDDEN = {
    "codec": ["importers", "services", "sdk", "cli", "bench", "tests", "testing", "proto", "parallel", "fec"],
    "importers": ["services", "sdk", "cli", "bench", "tests", "testing", "parallel", "fec"],
    # Concurrency primitives (the codec's TaskRunner, call limits): codec/core and the standard library only.
    "parallel": ["importers", "net", "services", "sdk", "cli", "bench", "tests", "testing", "proto", "fec"],
    # The codec's erasure code on ISA-L: codec/core and the library only.
    "fec": ["importers", "net", "services", "sdk", "cli", "bench", "tests", "testing", "proto", "parallel"],
    "net": ["services", "sdk", "cli", "bench", "tests", "testing"],
    # The generated API and the rules of its values (meshstream_common) that
    # clients and the server share: codec/, importers/ and the generated code.
    "proto": ["parallel", "fec", "net", "services", "sdk", "cli", "bench", "tests", "testing"],
    "services": ["sdk", "cli", "bench", "tests", "testing"],
    "sdk": ["services", "cli", "bench", "tests", "testing"],
    # The command line is the product too: what tests share is not for it.
    "cli": ["bench", "tests", "testing"],
    # The library tests/ and bench/ share; it serves them and uses none of them.
    "testing": ["cli", "bench", "tests"],
    # Benchmarks use the product and testing/, never the test suites.
    "bench": ["tests", "experiments"],
    # Research programs: the product, testing/ and bench/'s helpers.
    "experiments": ["tests"],
    # Programs on the public C API alone (the header is meshstream/meshstream.h).
    "examples": ["codec", "importers", "parallel", "fec", "net", "services", "sdk", "cli", "bench", "tests", "testing",
                 "proto", "web"],
    # The browser side's C ABI (web/wasm, compiled to WebAssembly): codec/ only.
    "web": ["importers", "parallel", "fec", "net", "services", "sdk", "cli", "bench", "tests", "testing", "proto"],
}
# Nothing depends on the research programs.
for _top, _forbidden in LAYER_FORBIDDEN.items():
    if _top != "experiments" and "experiments" not in _forbidden:
        _forbidden.append("experiments")
# The pure library does no I/O, keeps no clock and starts no thread.
CODEC_FORBIDDEN_STD = {"fstream", "iostream", "cstdio", "filesystem", "thread", "mutex", "shared_mutex",
                       "condition_variable", "future", "atomic", "chrono", "ctime"}
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')


def closure(folder, depends=CODEC_DEPENDS, seen=None):
    seen = set() if seen is None else seen
    for dep in depends[folder]:
        if dep not in seen:
            seen.add(dep)
            closure(dep, depends, seen)
    return seen


def sources(root, top):
    for dirpath, _, files in os.walk(os.path.join(root, top)):
        for name in sorted(files):
            if name.endswith((".h", ".c", ".cc", ".hpp", ".cpp")):
                yield os.path.join(dirpath, name)


LAYER_CALL = re.compile(r"meshstream_service_layer\(\s*(\w+)([^)]*)\)", re.S)
LAYER_KEYWORDS = {"LAYERS", "LIBS", "PRIVATE_LIBS"}


def check_service_targets(root):
    """services/CMakeLists.txt builds one library per folder whose LAYERS are
    the folder's SERVICES_DEPENDS: the build's order is the architecture's."""
    path = os.path.join(root, "services", "CMakeLists.txt")
    errors = []
    with open(path, encoding="utf-8") as f:
        text = re.sub(r"#[^\n]*", "", f.read())
    built = {}
    for folder, args in LAYER_CALL.findall(text):
        layers, current = [], None
        for word in args.split():
            if word in LAYER_KEYWORDS:
                current = word
            elif current == "LAYERS":
                layers.append(word)
        if folder in built:
            errors.append(f"services/CMakeLists.txt: services/{folder}/ built twice")
        built[folder] = layers
    for folder, depends in SERVICES_DEPENDS.items():
        if folder not in built:
            errors.append(f"services/CMakeLists.txt: no meshstream_service_layer({folder} ...)")
        elif sorted(built[folder]) != sorted(depends):
            errors.append(f"services/CMakeLists.txt: meshstream_{folder} links LAYERS {sorted(built[folder])}, "
                          f"docs/architecture.md draws {sorted(depends)}")
    for folder in built:
        if folder not in SERVICES_DEPENDS:
            errors.append(f"services/CMakeLists.txt: meshstream_{folder} is not a folder docs/architecture.md names")
    return errors


def main(root):
    errors = []
    checked = 0
    for top, forbidden in LAYER_FORBIDDEN.items():
        for path in sources(root, top):
            rel = os.path.relpath(path, root)
            parts = rel.split(os.sep)
            depends = FOLDER_DEPENDS.get(top)
            folder = parts[1] if depends is not None and len(parts) > 2 else None
            if depends is not None and folder not in depends:
                errors.append(f"{rel}: {top}/ file outside the folders docs/architecture.md names")
                continue
            with open(path, encoding="utf-8", errors="replace") as f:
                for number, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if not m:
                        continue
                    checked += 1
                    kind, target = m.groups()
                    close = ">" if kind == "<" else '"'
                    where = f"{rel}:{number}: #include {kind}{target}{close}"
                    head = target.split("/")[0]
                    if kind == '"' and head in forbidden:
                        errors.append(f"{where}: {top}/ may not depend on {head}/")
                    if (top == "cli" and kind == '"' and head == "services" and
                            rel.replace(os.sep, "/") not in CLI_SERVER_FILES):
                        errors.append(f"{where}: a client verb of cli/ uses proto/'s rules, not services/")
                    if top == "services" and kind == '"' and head == "services":
                        dep = target.split("/")[1] if target.count("/") >= 2 else None
                        if dep not in SERVICES_DEPENDS:
                            errors.append(f"{where}: not a services/ folder")
                        elif dep != folder and dep not in closure(folder, SERVICES_DEPENDS):
                            errors.append(f"{where}: services/{folder}/ may not use services/{dep}/ "
                                          f"(order in docs/architecture.md)")
                    if top != "codec":
                        continue
                    if kind == "<":
                        # The standard library only: no third-party header in the pure library.
                        if "/" in target or target.endswith((".h", ".hpp")):
                            errors.append(f"{where}: codec/ uses no third-party or C header")
                        elif target in CODEC_FORBIDDEN_STD:
                            errors.append(f"{where}: codec/ has no files, clocks or threads")
                        continue
                    if head != "codec":
                        errors.append(f"{where}: codec/ includes only codec/")
                        continue
                    dep = target.split("/")[1] if target.count("/") >= 2 else None
                    if dep not in CODEC_DEPENDS:
                        errors.append(f"{where}: not a codec/ folder")
                    elif dep != folder and dep not in closure(folder):
                        errors.append(f"{where}: codec/{folder}/ may not use codec/{dep}/ "
                                      f"(order in docs/architecture.md)")
    errors += check_service_targets(root)
    for e in errors:
        print(e)
    print(f"layout: {checked} includes checked, {len(errors)} pointing the wrong way")
    return 1 if errors or checked == 0 else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else os.getcwd()))
