# meshstream: the two commands of the README, plus the usual build targets.
#   make        Release build into build/ (the CLI lands at build/bin/meshstream)
#   make test   install what is missing, build, run every test
#   make demo   install what is missing, build, run the main job
#   make bench  benchmarks against Draco (JSON + plots into docs/)
SHELL := /bin/bash
BUILD ?= build
ASAN_BUILD ?= build-asan
TSAN_BUILD ?= build-tsan
# The decoder as WebAssembly (docs/design/web.md); the test of tests/web reads it from here.
WASM_BUILD := build-wasm
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
# ccache, where installed, makes rebuilds in fresh clones (CI) and worktrees cheap.
CCACHE := $(shell command -v ccache 2>/dev/null)
# Paths under the checkout are hashed relative to it, so every clone shares the cache.
ifneq ($(CCACHE),)
  CMAKE_FLAGS += -DCMAKE_CXX_COMPILER_LAUNCHER=$(CCACHE)
  export CCACHE_BASEDIR := $(CURDIR)
  export CCACHE_NOHASHDIR := 1
endif

.PHONY: all deps build wasm test test-asan test-tsan demo bench fuzz clean install

all: build

deps:
	@scripts/install-deps

$(BUILD)/build.ninja:
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

build: deps $(BUILD)/build.ninja
	cmake --build $(BUILD) -j $(JOBS)

test: build wasm test-asan test-tsan
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# codec/ and web/wasm's C ABI compiled by Debian's emscripten 3.1.6 into
# $(WASM_BUILD)/meshstream_decoder.cjs. NODE_PATH: NodeSource's node does not
# search Debian's JS modules, which emscripten's link step needs (docs/design/web.md).
# Then the viewer's bundle in $(BUILD)/web, which `meshstream serve --http-listen`
# serves at / (its default --http-root: beside the binary's folder).
wasm: deps
	@[ -f $(WASM_BUILD)/build.ninja ] || NODE_PATH=/usr/share/nodejs emcmake cmake -S web/wasm -B $(WASM_BUILD) \
	  -G Ninja -DCMAKE_BUILD_TYPE=Release
	NODE_PATH=/usr/share/nodejs cmake --build $(WASM_BUILD) -j $(JOBS)
	web/bundle.sh $(WASM_BUILD)/meshstream_decoder.cjs $(BUILD)/web

# The importers take hostile input: run their tests once under ASan+UBSan,
# compiled at -O1 with line tables only (-g1): what ASan's documentation
# advises, stack traces keep their file and line, and the build takes half
# the time of -O2 -g (the longest part of a cold `make test` after the main build).
SANITIZER_OPT := -O1 -g1 -DNDEBUG
test-asan: deps
	@[ -f $(ASAN_BUILD)/build.ninja ] || cmake -S . -B $(ASAN_BUILD) -G Ninja \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$(SANITIZER_OPT)" \
	  -DCMAKE_C_FLAGS_RELWITHDEBINFO="$(SANITIZER_OPT)" -DMESHSTREAM_SANITIZE=ON -DMESHSTREAM_ONLY_IMPORTERS=ON $(CMAKE_FLAGS)
	cmake --build $(ASAN_BUILD) -j $(JOBS) --target importer_checks
	cd $(ASAN_BUILD) && ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
	  ctest --output-on-failure -j $(JOBS) -L importers

# The parallel decode (threads sharing the decoder's state) once under
# ThreadSanitizer: the thread pool, the plans, and the one-thread/N-thread
# comparison on a synthetic mesh (only codec/ and parallel/ are built).
test-tsan: deps
	@[ -f $(TSAN_BUILD)/build.ninja ] || cmake -S . -B $(TSAN_BUILD) -G Ninja \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="$(SANITIZER_OPT)" \
	  -DCMAKE_C_FLAGS_RELWITHDEBINFO="$(SANITIZER_OPT)" -DMESHSTREAM_TSAN=ON -DMESHSTREAM_ONLY_IMPORTERS=ON $(CMAKE_FLAGS)
	cmake --build $(TSAN_BUILD) -j $(JOBS) --target parallel_race_tests
	cd $(TSAN_BUILD) && TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1" \
	  ctest --output-on-failure -j $(JOBS) -L parallel_race

demo: build wasm
	@scripts/demo

# Benchmarks (never part of `make test`): meshstream against Draco in one binary, gltfpack
# LODs; JSON, PNG plots and the tables of docs/results/benchmarks.md. BENCH_ARGS e.g. "--model spot".
# Then the loss experiments (docs/results/loss-results.md); LOSS_BENCH_ARGS e.g. "--quick". Then the
# asset service's and the streaming sessions' benchmarks (bench-service, bench-stream below).
PYTHON ?= $(shell [ -x /usr/bin/python3 ] && echo /usr/bin/python3 || echo python3)
BENCH_ARGS ?=
LOSS_BENCH_ARGS ?=
bench: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_rule_comparison --out docs/results/bench/rules.json
	$(BUILD)/bin/meshstream_bench --out docs/results/bench/results.json $(BENCH_ARGS)
	$(BUILD)/bin/meshstream_bench_scaling --out docs/results/bench/scaling.json $(SCALING_ARGS)
	$(PYTHON) bench/plot.py docs/results/bench/results.json --doc docs/results/benchmarks.md
	$(BUILD)/bin/meshstream_loss_bench --out docs/results/bench/loss.json $(LOSS_BENCH_ARGS)
	$(PYTHON) bench/plot_loss.py docs/results/bench/loss.json --doc docs/results/loss-results.md
	$(BUILD)/bin/meshstream_bench_service --out docs/results/bench/service.json $(SERVICE_BENCH_ARGS)
	$(PYTHON) bench/plot_service.py docs/results/bench/service.json --doc docs/results/service-benchmarks.md
	$(stream-bench)

# Only the asset service's benchmark (docs/results/service-benchmarks.md): `meshstream serve` in-process
# on SQLite and on a PostgreSQL cluster it starts (fsync on); SERVICE_BENCH_ARGS e.g. "--quick".
SERVICE_BENCH_ARGS ?=
.PHONY: bench-service
bench-service: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_bench_service --out docs/results/bench/service.json $(SERVICE_BENCH_ARGS)
	$(PYTHON) bench/plot_service.py docs/results/bench/service.json --doc docs/results/service-benchmarks.md

# Only the streaming sessions' benchmark (docs/results/stream-benchmarks.md): `meshstream serve` in-process
# on SQLite, SDK sessions over UDP and gRPC beside the Draco GLB export, the server's datagram rate
# beside a sendmmsg loop; STREAM_BENCH_ARGS e.g. "--quick".
# Then the shaped link again at 5 ms each way (docs/results/stream-benchmarks-near.md): the round trip
# that proves a UDP address is short enough there for part of the stream to travel over UDP, so
# that parity (docs/design/loss-protection.md) has something to protect; at 20 ms these models finish first.
STREAM_BENCH_ARGS ?=
define stream-bench
$(BUILD)/bin/meshstream_bench_stream --out docs/results/bench/stream.json $(STREAM_BENCH_ARGS)
$(PYTHON) bench/plot_stream.py docs/results/bench/stream.json --doc docs/results/stream-benchmarks.md
rm -f docs/results/bench/stream-near.json
$(BUILD)/bin/meshstream_bench_stream --only-shaped --shaped-delay-ms 5 --shaped-loss 0,12 --shaped-runs 9 --out docs/results/bench/stream-near.json $(STREAM_BENCH_ARGS)
$(PYTHON) bench/plot_stream.py docs/results/bench/stream-near.json --out docs/results/bench/stream-near --doc docs/results/stream-benchmarks-near.md
endef
.PHONY: bench-stream
bench-stream: build
	@mkdir -p docs/results/bench
	$(stream-bench)

# The native viewer's benchmark (docs/results/viewer-benchmarks.md): examples/viewer under Xvfb
# and Mesa's llvmpipe, frame times while refining against idle and the bytes uploaded to the GPU;
# VIEWER_BENCH_ARGS e.g. "--runs 5 --rate 2".
VIEWER_BENCH_ARGS ?=
.PHONY: bench-viewer
bench-viewer: build
	@mkdir -p docs/results/bench
	bench/viewer/run.sh $(BUILD)/bin/meshstream $(BUILD)/bin/meshstream_viewer ../shared/models docs/results/bench/viewer.json $(VIEWER_BENCH_ARGS)
	$(PYTHON) bench/plot_viewer.py docs/results/bench/viewer.json --doc docs/results/viewer-benchmarks.md

# The browser benchmark (docs/results/web-benchmarks.md): the viewer in headless Chromium against
# `meshstream serve --http-listen`, the Draco .glb with three.js alone beside the progressive file
# by HTTP ranges and over a WebSocket session, on loopback and on a shaped link (20 Mbit/s, 20 ms
# each way); the wasm decoder beside the native one. WEB_BENCH_ARGS e.g. "--runs 3".
WEB_BENCH_ARGS ?=
.PHONY: bench-web
bench-web: build wasm
	@mkdir -p docs/results/bench
	bench/web/run.sh $(BUILD)/bin/meshstream $(BUILD)/bin/meshstream_wasm_reference $(WASM_BUILD)/meshstream_decoder.cjs \
	  ../shared/models docs/results/bench/web.json $(WEB_BENCH_ARGS)
	$(PYTHON) bench/plot_web.py docs/results/bench/web.json --doc docs/results/web-benchmarks.md

# The soak (docs/results/stream-benchmarks.md, "Soak"): sessions opened at 20 per second for 30 minutes
# against a `meshstream serve` process, the clients in a network namespace losing 5 % (root);
# the server's memory over time. Not part of `make bench` (half an hour). SOAK_ARGS e.g. "--quick".
SOAK_ARGS ?=
# The encoder at scale (docs/results/benchmarks.md, "The encoder at scale"): the bunny subdivided to
# 2.2 M vertices, meshstream encode against Draco, time and peak memory (about 3 minutes).
.PHONY: bench-scaling bench-large
# A mesh of about 10 M vertices end to end (docs/results/large-assets.md): about 10 minutes, 10 GB.
bench-large: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_bench_large --out docs/results/bench/large.json $(LARGE_ARGS)

bench-scaling: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_bench_scaling --out docs/results/bench/scaling.json $(SCALING_ARGS)

# Ranged GETs of the stored progressive file (docs/results/http-ranges.md): the HTTP asset route from
# the store and from the session host's hot artifacts, on the bunny and the 557 k-vertex noisy bunny
# (about 2 minutes, most of it the large model's ingest). RANGES_ARGS e.g. "--quick".
RANGES_ARGS ?=
.PHONY: bench-ranges
bench-ranges: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_bench_ranges --out docs/results/bench/http-ranges.json $(RANGES_ARGS)
	$(PYTHON) bench/plot_ranges.py docs/results/bench/http-ranges.json --doc docs/results/http-ranges.md

.PHONY: bench-soak
bench-soak: build
	@mkdir -p docs/results/bench
	$(BUILD)/bin/meshstream_bench_soak --out docs/results/bench/soak.json $(SOAK_ARGS)

# The CLI, the C API's shared and static libraries, its header and meshstream.pc under
# $(PREFIX) (default /usr/local): `make install PREFIX=$$HOME/.local`. DESTDIR is honoured.
PREFIX ?= /usr/local
install: build
	DESTDIR=$(DESTDIR) cmake --install $(BUILD) --prefix $(PREFIX) --component cli
	DESTDIR=$(DESTDIR) cmake --install $(BUILD) --prefix $(PREFIX) --component c_api

# libFuzzer binaries (clang): the importers' and codec's in build-fuzz/ (ONLY_IMPORTERS), the
# service's parsers (fuzz_service_*, which link services/) in build-fuzz-services/.
fuzz: deps
	@[ -f build-fuzz/build.ninja ] || CXX=clang++ cmake -S . -B build-fuzz -G Ninja \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMESHSTREAM_FUZZ=ON -DMESHSTREAM_ONLY_IMPORTERS=ON
	cmake --build build-fuzz -j $(JOBS)
	@[ -f build-fuzz-services/build.ninja ] || CXX=clang++ cmake -S . -B build-fuzz-services -G Ninja \
	  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DMESHSTREAM_FUZZ=ON $(CMAKE_FLAGS)
	cmake --build build-fuzz-services -j $(JOBS) --target service_fuzzers
	@echo "run e.g.: build-fuzz/bin/fuzz_gltf tests/fuzz/corpus/gltf -max_total_time=60"
	@echo "      or: build-fuzz-services/bin/fuzz_service_ingest tests/fuzz/corpus/service_ingest -max_total_time=60"

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(TSAN_BUILD) build-fuzz build-fuzz-services
