# amctl: the two commands a new user needs.
#   make demo   install missing Debian packages, build, run the main job on a bundled example
#   make test   install missing Debian packages, build, run every test
#   make fuzz   build the libFuzzer targets (clang) and fuzz every reader for FUZZ_TIME s each
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

# libFuzzer on every reader (docs/testing.md), one target after the other, FUZZ_TIME s each;
# FUZZ_TARGETS="stl gcode" picks some. Each target's corpus lives in build/fuzz/corpus/<name>/:
# the checked-in seeds (fuzz/corpus/<name>/) are copied in, what earlier runs found is kept.
# Findings (crash-*, timeout-*, leak-*) land in build/fuzz/artifacts/<name>/; the recipe
# stops at the first target with a finding.
FUZZ_TIME ?= 60
FUZZ_DIR ?= build/fuzz
FUZZ_TARGETS ?= gcode machine_toml klipper_cfg accel_csv process_csv process_json stl sls_config macro_expr macro_stmt line_reader bgcode sliced_3mf marlin bed_mesh step_tuning
fuzz:
	cmake --preset fuzz
	cmake --build $(FUZZ_DIR) -j $(JOBS) $(addprefix --target fuzz_,$(FUZZ_TARGETS))
	@set -e; for t in $(FUZZ_TARGETS); do \
	  mkdir -p $(FUZZ_DIR)/corpus/$$t $(FUZZ_DIR)/artifacts/$$t; \
	  cp fuzz/corpus/$$t/* $(FUZZ_DIR)/corpus/$$t/; \
	  echo "== fuzz_$$t ($(FUZZ_TIME) s)"; \
	  $(FUZZ_DIR)/fuzz/fuzz_$$t -max_total_time=$(FUZZ_TIME) -rss_limit_mb=2048 -timeout=10 \
	    -dict=fuzz/dict/$$t.dict -artifact_prefix=$(FUZZ_DIR)/artifacts/$$t/ \
	    $(FUZZ_DIR)/corpus/$$t; \
	done

clean:
	rm -rf build
