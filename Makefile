# The README's two commands: `make demo` and `make test`. Both install missing packages first.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
# Ninja where installed (scripts/install-deps.sh installs it): it starts a stage's files while
# the stage before is still compiling, where make waits for each library (docs/build.md). A build
# folder keeps the generator it was configured with.
generator = $(if $(wildcard $(1)/CMakeCache.txt),,$(if $(shell command -v ninja),-G Ninja,))

.PHONY: all deps peers configure build test demo bench asan native fuzz clean

all: build

deps:
	@bash scripts/install-deps.sh

peers:
	@bash scripts/install-deps.sh --peers

configure: deps
	@cmake -S . -B $(BUILD_DIR) $(call generator,$(BUILD_DIR)) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS) > /dev/null

build: configure
	@cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	@cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS)

demo: build
	@$(BUILD_DIR)/apps/hazmap demo

bench: peers
	@cmake -S . -B $(BUILD_DIR) $(call generator,$(BUILD_DIR)) -DCMAKE_BUILD_TYPE=Release -DHAZMAP_BUILD_BENCH=ON $(CMAKE_FLAGS) > /dev/null
	@cmake --build $(BUILD_DIR) -j $(JOBS)
	@# Repetitions of all rows interleaved at random: the machine's drift hits every row alike.
	@for b in $(BUILD_DIR)/bench/bench_*; do [ -x "$$b" ] && "$$b" --benchmark_enable_random_interleaving=true || exit 1; done

asan: deps
	@cmake -S . -B build-asan $(call generator,build-asan) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHAZMAP_SANITIZE=ON > /dev/null
	@cmake --build build-asan -j $(JOBS)
	@cd build-asan && ctest --output-on-failure -j $(JOBS)

# -march=native (AVX/AVX-512 here): Eigen's fixed-size types become 32/64-byte aligned, so this
# build runs the suite where a misaligned Eigen member would fault (docs/build.md).
native: deps
	@cmake -S . -B build-native $(call generator,build-native) -DCMAKE_BUILD_TYPE=Release -DHAZMAP_NATIVE=ON > /dev/null
	@cmake --build build-native -j $(JOBS)
	@cd build-native && ctest --output-on-failure -j $(JOBS)

# libFuzzer with ASan + UBSan (clang, a build folder of its own): each target a few seconds
# (HAZMAP_FUZZ_SECONDS) on the seed corpus of the real shared data. `make test` replays the same
# targets' seeds and mutants in the normal build (fuzz/replay) instead.
fuzz: configure
	@bash scripts/install-deps.sh --fuzz
	@bash scripts/fuzz-smoke.sh $(CURDIR) $(abspath $(BUILD_DIR))

clean:
	rm -rf $(BUILD_DIR) build-asan build-native
