// Hot paths of the thermal module: the 1000-layer SLS build (target < 1 s), one PDE step,
// the exact G(s) evaluation and the margin computation.
#include <benchmark/benchmark.h>

#include <complex>

#include "amctl/thermal/powder_bed_sim.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"
#include "amctl/thermal/robust_margin.hpp"

using namespace amctl::thermal;

static void BM_SlsBuild1000Layers(benchmark::State& state) {
  SlsBuildConfig c;
  c.layers_added = 1000;
  c.csv_every = 0;
  c.coarsening.enabled = state.range(0) != 0;
  for (auto _ : state) {
    auto r = simulate_sls_build(c);
    benchmark::DoNotOptimize(r.final_abs_error_k);
  }
}
BENCHMARK(BM_SlsBuild1000Layers)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

static void BM_HeatColumnStepTrBdf2(benchmark::State& state) {
  HeatColumn col(PowderMaterial{}, 5e-5, int(state.range(0)), 170.0);
  for (auto _ : state) {
    col.step(0.25, 100.0);
    benchmark::DoNotOptimize(col.top_temp_c());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_HeatColumnStepTrBdf2)->Arg(100)->Arg(2000);

static void BM_ExactTransferFunction(benchmark::State& state) {
  const PowderBedTf g(PowderMaterial{}, 1e-4);
  double w = 1e-3;
  for (auto _ : state) {
    benchmark::DoNotOptimize(g.eval({0.0, w}));
    w = w < 1e9 ? w * 1.01 : 1e-3;
  }
}
BENCHMARK(BM_ExactTransferFunction);

static void BM_SlsMarginsPaperPi(benchmark::State& state) {
  const PowderBedTf g(PowderMaterial{}, 1e-4);
  for (auto _ : state) {
    auto r = compute_margins(g, amctl::control::PidGains::standard(0.3, 0.5), 1);
    benchmark::DoNotOptimize(r.margin_on_g_sweep);
  }
}
BENCHMARK(BM_SlsMarginsPaperPi)->Unit(benchmark::kMillisecond);

#include "amctl/thermal/fdm_heater.hpp"

static void BM_HotendScenarioMpc(benchmark::State& state) {
  const HeaterPlantParams p = HeaterPlantParams::hotend();
  const MpcModel m{};
  const HeaterScenario sc{};
  for (auto _ : state) {
    MpcController mpc(m, MpcOptions{}, p.ambient_c);
    auto r = run_heater_scenario(p, sc,
        [&](double t, double y, double f, double q, double dt) { return mpc.update(t, y, f, q, dt); },
        "mpc");
    benchmark::DoNotOptimize(r.flow_ripple_k);
  }
}
BENCHMARK(BM_HotendScenarioMpc)->Unit(benchmark::kMillisecond);

static void BM_RelayAutotuneHotend(benchmark::State& state) {
  for (auto _ : state) {
    auto r = relay_autotune(HeaterPlant(HeaterPlantParams::hotend()), AutotuneOptions{});
    benchmark::DoNotOptimize(r.ku);
  }
}
BENCHMARK(BM_RelayAutotuneHotend)->Unit(benchmark::kMillisecond);

static void BM_IdentifyMpcModel(benchmark::State& state) {
  for (auto _ : state) {
    auto r = identify_mpc_model(HeaterPlant(HeaterPlantParams::hotend()), IdentifyOptions{});
    benchmark::DoNotOptimize(r.model.block_capacity_j_k);
  }
}
BENCHMARK(BM_IdentifyMpcModel)->Unit(benchmark::kMillisecond);
