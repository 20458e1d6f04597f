# amctl: the two commands a new user needs.
#   make demo   install missing Debian packages, build, run the main job on a bundled example
#   make test   install missing Debian packages, build, run every test
BUILD_DIR ?= build/release
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: all deps build demo test bench clean

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

clean:
	rm -rf build
