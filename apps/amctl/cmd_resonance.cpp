// `amctl resonance calibrate FILE --axis x|y [--sweep F0,F1,RATE,ACCEL] [--json] [--csv OUT]`: Klipper's input-shaper
// calibration of an accelerometer record or PSD (resonance/calibrate.hpp; docs/resonance.md).
// `amctl resonance test-gcode --machine SPEC --axis x|y [-o FILE] [--style klipper|marlin] ...`:
// resonance-test G-code (resonance/test_gcode.hpp).
#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/memory.hpp"
#include "amctl/core/output.hpp"
#include "amctl/process/csv.hpp"
#include "amctl/resonance/calibrate.hpp"
#include "amctl/resonance/test_gcode.hpp"
#include "amctl/tuning/recommend.hpp"
#include "commands.hpp"
#include "machine_cli.hpp"

namespace amctl::cli {
namespace {

struct CalibrateArgs {
  std::vector<std::string> files;
  std::string axis;
  std::string csv;
  std::string sweep;
  std::string response_csv;
  std::optional<int> modes;
  bool json = false;
  bool recommend = false;
  MachineOptions machine;
  std::optional<double> max_smoothing_mm;
};

struct RecommendArgs {
  double natural_frequency_hz = 0.0;
  double damping_ratio = 0.0;
  MachineOptions machine;
  std::optional<double> max_smoothing_mm;
  bool json = false;
};

tuning::RecommendOptions recommend_options(const std::optional<double>& max_smoothing_mm) {
  tuning::RecommendOptions o;
  if (max_smoothing_mm) o.max_smoothing_mm = *max_smoothing_mm;
  return o;
}

struct TestGcodeArgs {
  MachineOptions machine;
  std::string axis;
  std::string output;
  std::string style = "klipper";
  std::optional<double> freq_start, freq_end, accel_per_hz, accel, hz_per_sec;
  std::string point;
  bool no_home = false;
};

void run_test_gcode(const TestGcodeArgs& a) {
  const machine::Machine m = resolve_machine(a.machine);
  // The machine's own: [resonance_tester] (probe points, chip, frequencies) or the middle of its
  // position limits; the flags below override.
  resonance::TestGcodeOptions o = resonance::machine_test_options(
      a.style == "marlin" ? resonance::TestStyle::marlin : resonance::TestStyle::klipper, a.axis.front(), m);
  o.home = !a.no_home;
  if (a.style == "marlin" && a.accel_per_hz) throw Error("--accel-per-hz applies to --style klipper; use --accel-mm-s2");
  if (a.style != "marlin" && a.accel) throw Error("--accel-mm-s2 applies to --style marlin; use --accel-per-hz");
  if (a.freq_start) o.freq_start_hz = *a.freq_start;
  if (a.freq_end) o.freq_end_hz = *a.freq_end;
  if (a.accel_per_hz) {
    // Klipper's accel_per_hz times the highest frequency is the test's largest acceleration.
    require_range_flag("--accel-per-hz", PhysicalRange{"acceleration per Hz", "mm/s^2/Hz", 1e-3, 1e5}, *a.accel_per_hz);
    o.accel_per_hz = *a.accel_per_hz;
  }
  if (a.accel) {
    if (*a.accel > 0.0) require_range_flag("--accel-mm-s2", kAccelRange, *a.accel);  // <= 0: the library's message
    o.accel_mm_s2 = *a.accel;
  }
  if (a.hz_per_sec) o.hz_per_sec = *a.hz_per_sec;
  if (!a.point.empty()) {
    double v[3];
    std::size_t start = 0;
    for (int i = 0; i < 3; ++i) {
      const std::size_t comma = a.point.find(',', start);
      if ((i < 2) != (comma != std::string::npos)) {
        throw Error(fmt::format("--point: found '{}', expected X,Y,Z", a.point));
      }
      const std::string field = a.point.substr(start, i < 2 ? comma - start : std::string::npos);
      std::size_t used = 0;
      try {
        v[i] = std::stod(field, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (field.empty() || used != field.size() || !std::isfinite(v[i])) {
        throw Error(fmt::format("--point: '{}' in '{}' is not a finite number, expected X,Y,Z", field, a.point));
      }
      start = comma + 1;
    }
    for (int i = 0; i < 3; ++i) o.point_mm[i] = v[i];
    o.point_given = true;
    o.probe_points.clear();
    o.point_source = "--point";
    o.probe_point_locations.clear();
  }
  const std::string text = resonance::test_gcode(o, m);  // whole text first: all or nothing
  write_output(a.output.empty() ? "-" : a.output, text, OutputOptions{"-o/--output", {}, {}});
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
  cal->add_option("FILE", a->files,
                  "Accelerometer CSV or PSD CSV ('-' reads standard input); several files join "
                  "one fit, as calibrate_shaper.py A.csv B.csv")
      ->required();
  cal->add_option("--axis", a->axis,
                  "The axis the record excited: x or y (reports that axis's peak; needed by "
                  "--sweep; the fit, as Klipper's, uses x+y+z)")
      ->check(CLI::IsMember({"x", "y"}));
  cal->add_option("--sweep", a->sweep,
                  "The commanded sweep F0,F1,RATE,ACCEL (Hz, Hz, Hz/s, mm/s^2): adds the "
                  "frequency response and a modal fit (natural frequency, damping ratio, gain)");
  cal->add_option("--modes", a->modes,
                  "With --sweep: the number of modes fitted, 1 to 3 (default: chosen by BIC)");
  cal->add_option("--response-csv", a->response_csv,
                  "With --sweep: write the frequency response, its coherence and the model's "
                  "to this file");
  cal->add_flag("--json", a->json, "Print one JSON object");
  cal->add_option("--csv", a->csv,
                  "Write the PSD (freq,psd_x,psd_y,psd_z,psd_xyz; unnormalised, as Klipper's "
                  "TEST_RESONANCES) to this file");
  cal->add_flag("--recommend", a->recommend,
                "With --sweep: the shaper and frequency that minimise the simulated contour error of "
                "the fitted model on a ringing-tower path within the smoothing budget "
                "(`model_recommendation` in the JSON)");
  add_machine_options(*cal, a->machine);
  cal->add_option("--max-smoothing-mm", a->max_smoothing_mm,
                  "With --recommend: smoothing budget [mm] (Klipper's measure at the machine's accel, scv 5; default 0.12)");
  cal->callback([a] {
    if (a->json && (a->csv == "-" || a->response_csv == "-")) {
      throw Error("--json: standard output would hold the CSV too, expected --csv/--response-csv in files");
    }
    resonance::CalibrateOptions o;
    o.axis = a->axis.empty() ? '\0' : a->axis.front();
    if (!a->sweep.empty()) o.sweep = resonance::parse_sweep(a->sweep);
    if (o.sweep && o.axis == 0) {
      throw Error(SourceLocation{"--axis", 0, 0},
                  "found --sweep without --axis, expected the axis the sweep excited (x or y)");
    }
    if (a->files.size() > 1 && (!a->csv.empty() || !a->response_csv.empty())) {
      throw Error(SourceLocation{a->csv.empty() ? "--response-csv" : "--csv", 0, 0},
                  "found several files, expected one with this flag");
    }
    if (a->modes) {
      if (!o.sweep) throw Error("--modes needs --sweep (the modes are fitted to the sweep's response)");
      if (*a->modes < 1 || *a->modes > resonance::kMaxModes) {
        throw Error(fmt::format("--modes: must be 1 to {}, got {}", resonance::kMaxModes, *a->modes));
      }
      o.modes = *a->modes;
    }
    if (a->recommend && !o.sweep) throw Error("--recommend needs --sweep (the modal model comes from the sweep's fit)");
    if (a->max_smoothing_mm && !a->recommend) throw Error("--max-smoothing-mm needs --recommend");
    const tuning::RecommendOptions ro = recommend_options(a->max_smoothing_mm);
    // A record is held whole (the analysis reads it several times): said before reading it
    // when it is large, refused when the machine cannot hold it.
    for (const std::string& file : a->files) {
      const auto size = resonance::estimate_record_size(file);
      if (!size) continue;
      const std::uint64_t avail = available_memory_bytes();
      if (avail != 0 && size->memory_bytes > avail) {
        throw Error(SourceLocation{file, 0, 0},
                    fmt::format("about {} samples would take about {} of memory, more than the {} available; "
                                "expected a shorter record",
                                size->samples, memory_text(size->memory_bytes), memory_text(avail)));
      }
      if (size->samples > 1000000) {
        std::cerr << fmt::format("amctl: note: {}: about {} samples; reading and analysing them takes about {} "
                                 "of memory\n",
                                 file, size->samples, memory_text(size->memory_bytes));
      }
    }
    const resonance::CalibrationReport r = resonance::calibrate_files(a->files, o);
    std::optional<tuning::Recommendation> rec;
    if (a->recommend) {
      const machine::Machine m = resolve_machine(a->machine);
      const resonance::ModalFit& fit = r.identification->model;
      rec = tuning::recommend({fit.natural_frequency_hz, fit.damping_ratio}, m, ro, r.klipper.recommended);
    }
    require_distinct_outputs(a->csv, "--csv", a->response_csv, "--response-csv");
    // The records and the machine file named (read only with --recommend) are never outputs.
    std::vector<std::string> inputs = a->files;
    inputs.push_back(a->machine.spec);
    if (!a->csv.empty()) resonance::write_psd_csv(r, a->csv, OutputOptions{"--csv", inputs, {}});
    if (!a->response_csv.empty()) {
      resonance::write_response_csv(r, a->response_csv, OutputOptions{"--response-csv", inputs, {}});
    }
    if (a->csv == "-" || a->response_csv == "-") return;  // standard output holds the CSV
    if (a->json) {
      Json j = resonance::to_json(r);
      if (rec) {
        Json rj = tuning::to_json(*rec);
        j["model_recommendation"] = rj["model_recommendation"];
        rj.erase("model");  // the fit is under "model" already
        j["recommendation"] = std::move(rj);
      }
      std::cout << j.dump(2) << "\n";
    } else {
      std::cout << resonance::to_text(r);
      if (rec) std::cout << "\nrecommendation from the fitted model (simulated):\n" << tuning::to_text(*rec);
    }
  });

  auto ra = std::make_shared<RecommendArgs>();
  CLI::App* rc = res->add_subcommand(
      "recommend", "The shaper and frequency that minimise the simulated contour error of a modal model on "
                   "a ringing-tower path within a smoothing budget, beside Klipper's pick for the model");
  rc->add_option("--natural-frequency-hz", ra->natural_frequency_hz, "The mode's natural frequency [Hz]")->required();
  rc->add_option("--damping-ratio", ra->damping_ratio, "The mode's damping ratio")->required();
  add_machine_options(*rc, ra->machine);
  rc->add_option("--max-smoothing-mm", ra->max_smoothing_mm,
                 "Smoothing budget [mm] (Klipper's measure at the machine's accel, scv 5; default 0.12)");
  rc->add_flag("--json", ra->json, "Print one JSON object");
  rc->callback([ra] {
    // A machine's resonance (Klipper tests 5-200 Hz); the simulation samples 30 per period, so
    // 10 kHz is also the highest its 1 MHz sample-rate bound allows.
    require_range_flag("--natural-frequency-hz", PhysicalRange{"resonance frequency", "Hz", 1.0, 1e4},
                       ra->natural_frequency_hz);
    const machine::Machine m = resolve_machine(ra->machine);
    const tuning::ModalModel model{ra->natural_frequency_hz, ra->damping_ratio};
    const tuning::RecommendOptions ro = recommend_options(ra->max_smoothing_mm);
    const tuning::Recommendation rec = tuning::recommend(model, m, ro, tuning::klipper_pick_for_model(model, ra->max_smoothing_mm));
    if (ra->json) {
      std::cout << tuning::to_json(rec).dump(2) << "\n";
    } else {
      std::cout << tuning::to_text(rec);
    }
  });

  auto t = std::make_shared<TestGcodeArgs>();
  CLI::App* tg = res->add_subcommand(
      "test-gcode", "A whole resonance-test program: homing, Klipper's TEST_RESONANCES move pattern (or a "
                    "Marlin-style sweep) at each test point, recorded by the accelerometer commands");
  add_machine_options(*tg, t->machine);
  tg->add_option("--axis", t->axis, "The axis to excite: x or y")->required()->check(CLI::IsMember({"x", "y"}));
  tg->add_option("-o,--output", t->output, "Write the G-code to this file (atomically; default: standard output)");
  tg->add_option("--style", t->style, "klipper (accel per Hz, Klipper's defaults) or marlin (constant accel)")
      ->check(CLI::IsMember({"klipper", "marlin"}));
  tg->add_option("--freq-start", t->freq_start, "Start frequency [Hz] (default: [resonance_tester] min_freq, else 5)");
  tg->add_option("--freq-end", t->freq_end,
                 "End frequency [Hz] (default: [resonance_tester] max_freq, else klipper 135, marlin 80)");
  tg->add_option("--accel-per-hz", t->accel_per_hz,
                 "klipper style: acceleration per Hz [mm/s^2/Hz] (default: [resonance_tester] accel_per_hz, else 60)");
  tg->add_option("--accel-mm-s2", t->accel, "marlin style: acceleration amplitude [mm/s^2] (default 4000)");
  tg->add_option("--hz-per-sec", t->hz_per_sec,
                 "Sweep rate [Hz/s] (default: [resonance_tester] hz_per_sec, else klipper 1, marlin 4)");
  tg->add_option("--point", t->point,
                 "Test point X,Y,Z [mm] (default: the machine's [resonance_tester] probe_points, else the "
                 "middle of its X/Y position limits 20 mm up, else 100,100,20)");
  tg->add_flag("--no-home", t->no_home, "Leave out the G28 at the start (the printer is homed already)");
  tg->callback([t] { run_test_gcode(*t); });
}

}  // namespace amctl::cli
