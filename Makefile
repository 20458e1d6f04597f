# amctl: the two commands a new user needs.
#   make demo   install missing Debian packages, build, run the main job on a bundled example
#   make test   install missing Debian packages, build, run every test
#   make fuzz   build the libFuzzer target (clang) and fuzz the G-code reader for FUZZ_TIME s
BUILD_DIR ?= build/release
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: all deps build demo test bench fuzz clean

all: build

deps:
	@scripts/install-deps.sh --with-slicer

$(BUILD_DIR)/CMakeCache.txt:
	cmake --preset release $(CMAKE_FLAGS)

build: deps $(BUILD_DIR)/CMakeCache.txt
	cmake --build $(BUILD_DIR) -j $(JOBS)

demo: build
	@scripts/demo.sh $(BUILD_DIR)

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 600

bench: build
	$(BUILD_DIR)/bench/amctl_bench --benchmark_min_time=0.2

# libFuzzer on the G-code reader + planner (docs/testing.md). The seed corpus is copied so
# the checked-in one is never modified; findings (crash-*, timeout-*, leak-*) land in
# build/fuzz/artifacts/.
FUZZ_TIME ?= 60
FUZZ_DIR ?= build/fuzz
fuzz:
	cmake --preset fuzz
	cmake --build $(FUZZ_DIR) -j $(JOBS) --target fuzz_gcode
	rm -rf $(FUZZ_DIR)/corpus && mkdir -p $(FUZZ_DIR)/corpus $(FUZZ_DIR)/artifacts
	cp fuzz/corpus/gcode/* $(FUZZ_DIR)/corpus/
	$(FUZZ_DIR)/fuzz/fuzz_gcode -max_total_time=$(FUZZ_TIME) -rss_limit_mb=2048 -timeout=10 \
	  -artifact_prefix=$(FUZZ_DIR)/artifacts/ $(FUZZ_DIR)/corpus

clean:
	rm -rf build
