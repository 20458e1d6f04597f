#!/usr/bin/env bash
# The whole suite under AddressSanitizer + UndefinedBehaviorSanitizer (docs/testing.md): every
# CTest entry of the `asan` preset (C++ only; the real-print closed-loop tests last, alone),
# then the Python tests against the extension built with the same sanitizers, run by Debian's
# /usr/bin/python3 with the ASan runtime preloaded. Not part of `make test`: about an hour of
# 2 cores (the build alone 25 min without ccache).
#
#   scripts/sanitize_suite.sh            # everything
#   STAGE=cxx scripts/sanitize_suite.sh  # C++ only; STAGE=python: Python only
#
# Logs and timings go to build/sanitize/. Exit status: non-zero when any stage failed.
set -uo pipefail
cd "$(dirname "$0")/.."
JOBS=${JOBS:-2}
STAGE=${STAGE:-all}
OUT="$PWD/build/sanitize"
mkdir -p "$OUT"
# The real-print closed-loop tests take minutes each under ASan: run after the rest.
SLOW='^closedloop_tests\.RealPrints\.'
status=0
timed() {  # timed NAME CMD...: wall and CPU time of CMD into $OUT/NAME.time
  local name=$1; shift
  /usr/bin/time -f "%e s wall, %U s user, %S s sys" -o "$OUT/$name.time" "$@"
}

if [[ $STAGE == all || $STAGE == cxx ]]; then
  cmake --preset asan -DAMCTL_PYTHON=OFF >"$OUT/cxx_configure.log" || exit 1
  timed cxx_build nice -n 10 cmake --build build/asan -j"$JOBS" >"$OUT/cxx_build.log" 2>&1 || exit 1
  (cd build/asan && timed cxx_tests nice -n 10 ctest -j"$JOBS" -E "$SLOW" --output-on-failure \
     >"$OUT/cxx_tests.log" 2>&1) || status=1
  (cd build/asan && timed cxx_real_prints nice -n 10 ctest -j"$JOBS" -R "$SLOW" --output-on-failure \
     >"$OUT/cxx_real_prints.log" 2>&1) || status=1
  tail -n 3 "$OUT/cxx_tests.log" "$OUT/cxx_real_prints.log"
fi

if [[ $STAGE == all || $STAGE == python ]]; then
  # The extension and the libraries it links, position-independent, with the sanitizers.
  cmake -S . -B build/asan-python -G Ninja -DCMAKE_BUILD_TYPE=Debug -DAMCTL_SANITIZE=ON \
    -DAMCTL_PYTHON=ON -DAMCTL_BUILD_TESTS=OFF -DAMCTL_BUILD_BENCH=OFF \
    -DPython3_EXECUTABLE=/usr/bin/python3 >"$OUT/python_configure.log" || exit 1
  timed python_build nice -n 10 cmake --build build/asan-python -j"$JOBS" --target _amctl amctl \
    >"$OUT/python_build.log" 2>&1 || exit 1
  # CPython allocates at exit what it never frees (by design): leak reports would be noise,
  # so LeakSanitizer is off; every other ASan and UBSan report aborts the test that makes it.
  # The CLI the tests compare with is the sanitized one, under the same runtime.
  (LD_PRELOAD="$(gcc -print-file-name=libasan.so)" \
   ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
   PYTHONPATH=build/asan-python/python AMCTL_CLI=build/asan-python/apps/amctl/amctl \
   AMCTL_SOURCE_DIR="$PWD" PYTHONDONTWRITEBYTECODE=1 \
   timed python_tests nice -n 10 /usr/bin/python3 -m pytest -q -c python/tests/pytest.ini python/tests \
     >"$OUT/python_tests.log" 2>&1) || status=1
  tail -n 3 "$OUT/python_tests.log"
fi
exit $status
