// Hot paths of resonance identification.
//   BM_CalibrateRecord30s   Klipper's calibration (Welch PSD of 3 axes + the fit of 5 shapers
//                           over ~2 950 frequencies + the recommendation) of a 30 s record at
//                           3.2 kHz (96 000 samples), already in memory: the issue's < 50 ms.
//   BM_ReadAndCalibrate30s  the same from the CSV text (parsing included).
//   BM_WelchPsd30s          the Welch PSD alone.
//   BM_IdentifySweep30s     --sweep: alignment (start and clock scale), H1, the modal fit.
#include <benchmark/benchmark.h>

#include <string>

#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/sweep.hpp"
#include "amctl/resonance/synthetic.hpp"

namespace {

using namespace amctl::resonance;

const std::string& record_text() {
  static const std::string text = [] {
    SyntheticSweep s;
    s.natural_freq_hz = 42.0;
    s.damping_ratio = 0.08;
    s.f0_hz = 5.0;
    s.f1_hz = 150.0;
    s.rate_hz_s = 5.0;  // 29 s of sweep + 2 x 0.5 s of rest
    s.sample_rate_hz = 3200.0;
    return synthetic_sweep_csv(s);
  }();
  return text;
}

const AccelFile& record() {
  static const AccelFile f = parse_accel_text(record_text(), "bench");
  return f;
}

void BM_CalibrateRecord30s(benchmark::State& state) {
  const AccelFile& f = record();
  CalibrateOptions o;
  o.axis = 'x';
  for (auto _ : state) {
    CalibrationReport r = calibrate(f, "bench", o);
    benchmark::DoNotOptimize(r);
  }
  state.counters["samples"] = static_cast<double>(f.record.size());
}
BENCHMARK(BM_CalibrateRecord30s)->Unit(benchmark::kMillisecond);

void BM_ReadAndCalibrate30s(benchmark::State& state) {
  const std::string& text = record_text();
  CalibrateOptions o;
  o.axis = 'x';
  for (auto _ : state) {
    CalibrationReport r = calibrate(parse_accel_text(text, "bench"), "bench", o);
    benchmark::DoNotOptimize(r);
  }
  state.counters["MB"] = static_cast<double>(text.size()) / 1e6;
}
BENCHMARK(BM_ReadAndCalibrate30s)->Unit(benchmark::kMillisecond);

void BM_WelchPsd30s(benchmark::State& state) {
  const AccelFile& f = record();
  for (auto _ : state) {
    WelchPsd w = klipper_psd(f.record);
    benchmark::DoNotOptimize(w);
  }
}
BENCHMARK(BM_WelchPsd30s)->Unit(benchmark::kMillisecond);

void BM_IdentifySweep30s(benchmark::State& state) {
  const AccelFile& f = record();
  const SweepExcitation sweep{5.0, 150.0, 5.0, 3000.0};
  for (auto _ : state) {
    SweepIdentification id = identify_sweep(f.record, 'x', sweep);
    benchmark::DoNotOptimize(id);
  }
}
BENCHMARK(BM_IdentifySweep30s)->Unit(benchmark::kMillisecond);

}  // namespace
