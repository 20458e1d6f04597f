// `amctl resonance calibrate FILE --axis x|y [--sweep F0,F1,RATE,ACCEL] [--json] [--csv OUT]`: Klipper's input-shaper
// calibration of an accelerometer record or PSD (resonance/calibrate.hpp; docs/resonance.md).
#include <iostream>
#include <memory>
#include <string>

#include "amctl/resonance/calibrate.hpp"
#include "commands.hpp"

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
}

}  // namespace amctl::cli
