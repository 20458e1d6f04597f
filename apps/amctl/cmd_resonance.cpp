// `amctl resonance calibrate FILE --axis x|y [--sweep F0,F1,RATE,ACCEL] [--json] [--csv OUT]`: Klipper's input-shaper
// calibration of an accelerometer record or PSD (resonance/calibrate.hpp; docs/resonance.md).
// `amctl resonance test-gcode --machine SPEC --axis x|y [-o FILE] [--style klipper|marlin] ...`:
// resonance-test G-code (resonance/test_gcode.hpp).
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/test_gcode.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct CalibrateArgs {
  std::string file;
  std::string axis;
  std::string csv;
  std::string sweep;
  std::string response_csv;
  bool json = false;
};

struct TestGcodeArgs {
  MachineOptions machine;
  std::string axis;
  std::string output;
  std::string style = "klipper";
  std::optional<double> freq_start, freq_end, accel_per_hz, accel, hz_per_sec;
  std::string point;
};

void run_test_gcode(const TestGcodeArgs& a) {
  const machine::Machine m = resolve_machine(a.machine);
  resonance::TestGcodeOptions o = resonance::default_test_options(
      a.style == "marlin" ? resonance::TestStyle::marlin : resonance::TestStyle::klipper);
  o.axis = a.axis.front();
  if (a.freq_start) o.freq_start_hz = *a.freq_start;
  if (a.freq_end) o.freq_end_hz = *a.freq_end;
  if (a.accel_per_hz) o.accel_per_hz = *a.accel_per_hz;
  if (a.accel) o.accel_mm_s2 = *a.accel;
  if (a.hz_per_sec) o.hz_per_sec = *a.hz_per_sec;
  if (!a.point.empty()) {
    double v[3];
    std::size_t start = 0;
    for (int i = 0; i < 3; ++i) {
      const std::size_t comma = a.point.find(',', start);
      if ((i < 2) != (comma != std::string::npos)) {
        throw Error(fmt::format("--point '{}': expected X,Y,Z", a.point));
      }
      const std::string field = a.point.substr(start, i < 2 ? comma - start : std::string::npos);
      std::size_t used = 0;
      try {
        v[i] = std::stod(field, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (field.empty() || used != field.size() || !std::isfinite(v[i])) {
        throw Error(fmt::format("--point '{}': '{}' is not a number, expected X,Y,Z", a.point, field));
      }
      start = comma + 1;
    }
    for (int i = 0; i < 3; ++i) o.point_mm[i] = v[i];
    o.point_given = true;
  }
  const std::string text = resonance::test_gcode(o, m);  // whole text first: all or nothing
  if (a.output.empty() || a.output == "-") {
    std::cout << text;
  } else {
    process::write_file_atomic(a.output, text);
  }
  if (!o.point_given) {
    std::cerr << fmt::format("amctl: note: test point {:g},{:g},{:g} (default; the machine's position limits are not known)\n",
                             o.point_mm[0], o.point_mm[1], o.point_mm[2]);
  }
}

}  // namespace

void register_resonance(CLI::App& app) {
  CLI::App* res = app.add_subcommand("resonance", "Resonance identification from accelerometer data");
  res->require_subcommand(1);

  auto a = std::make_shared<CalibrateArgs>();
  CLI::App* cal = res->add_subcommand(
      "calibrate", "Klipper's input-shaper calibration (Welch PSD, shaper fit, recommendation) of "
                   "a Klipper raw CSV, a corpus CSV or a Klipper PSD CSV");
  cal->add_option("FILE", a->file, "Accelerometer CSV or PSD CSV")->required();
  cal->add_option("--axis", a->axis, "The axis the record excited: x or y")
      ->required()
      ->check(CLI::IsMember({"x", "y"}));
  cal->add_option("--sweep", a->sweep,
                  "The commanded sweep F0,F1,RATE,ACCEL (Hz, Hz, Hz/s, mm/s^2): adds the "
                  "frequency response and a modal fit (natural frequency, damping ratio, gain)");
  cal->add_option("--response-csv", a->response_csv,
                  "With --sweep: write the frequency response, its coherence and the model's "
                  "to this file");
  cal->add_flag("--json", a->json, "Print one JSON object");
  cal->add_option("--csv", a->csv,
                  "Write the PSD (freq,psd_x,psd_y,psd_z,psd_xyz; unnormalised, as Klipper's "
                  "TEST_RESONANCES) to this file");
  cal->callback([a] {
    resonance::CalibrateOptions o;
    o.axis = a->axis.front();
    if (!a->sweep.empty()) o.sweep = resonance::parse_sweep(a->sweep);
    const resonance::CalibrationReport r = resonance::calibrate_file(a->file, o);
    if (!a->csv.empty()) resonance::write_psd_csv(r, a->csv);
    if (!a->response_csv.empty()) resonance::write_response_csv(r, a->response_csv);
    if (a->json) {
      std::cout << resonance::to_json(r).dump(2) << "\n";
    } else {
      std::cout << resonance::to_text(r);
    }
  });

  auto t = std::make_shared<TestGcodeArgs>();
  CLI::App* tg = res->add_subcommand(
      "test-gcode", "Resonance-test G-code: Klipper's TEST_RESONANCES move pattern or a Marlin-style "
                    "sweep, as plain G-code");
  add_machine_options(*tg, t->machine);
  tg->add_option("--axis", t->axis, "The axis to excite: x or y")->required()->check(CLI::IsMember({"x", "y"}));
  tg->add_option("-o,--output", t->output, "Write the G-code to this file (atomically; default: standard output)");
  tg->add_option("--style", t->style, "klipper (accel per Hz, Klipper's defaults) or marlin (constant accel)")
      ->check(CLI::IsMember({"klipper", "marlin"}));
  tg->add_option("--freq-start", t->freq_start, "Start frequency [Hz] (default 5)");
  tg->add_option("--freq-end", t->freq_end, "End frequency [Hz] (default: klipper 135, marlin 80)");
  tg->add_option("--accel-per-hz", t->accel_per_hz, "klipper style: acceleration per Hz [mm/s^2/Hz] (default 60)");
  tg->add_option("--accel-mm-s2", t->accel, "marlin style: acceleration amplitude [mm/s^2] (default 4000)");
  tg->add_option("--hz-per-sec", t->hz_per_sec, "Sweep rate [Hz/s] (default: klipper 1, marlin 4)");
  tg->add_option("--point", t->point, "Test point X,Y,Z [mm] (default 100,100,20)");
  tg->callback([t] { run_test_gcode(*t); });
}

}  // namespace amctl::cli
