#include <benchmark/benchmark.h>

#include "amctl/core/error.hpp"

// Validation helpers run on every parsed parameter; they must be free.
static void BM_RequirePositive(benchmark::State& state) {
  double v = 1.0;
  for (auto _ : state) {
    amctl::require_positive("v", v);
    benchmark::DoNotOptimize(v);
  }
}
BENCHMARK(BM_RequirePositive);
