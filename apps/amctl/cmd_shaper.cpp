// `amctl shaper show --type T --freq-hz F --damping-ratio Z [--residual-at-hz F1,F2,...]
//  [--test-damping-ratio Z2] [--json]`: one input shaper's impulses and Klipper's figures
// for it (shaping/report.hpp; docs/shaping.md).
#include <iostream>
#include <cmath>
#include <memory>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/shaping/report.hpp"
#include "commands.hpp"

namespace amctl::cli {
namespace {

struct ShowArgs {
  shaping::ShaperReportOptions options;
  double test_damping_ratio = 0.0;
  std::string firmware;
  bool json = false;
};

}  // namespace

void register_shaper(CLI::App& app) {
  CLI::App* shaper = app.add_subcommand("shaper", "Input shapers (ZV, MZV, ZVD, EI, ...) of Klipper and Marlin");
  shaper->require_subcommand(1);

  auto a = std::make_shared<ShowArgs>();
  CLI::App* show = shaper->add_subcommand(
      "show", "Impulses, smoothing, max accel and residual vibration of one shaper (Klipper's "
              "definitions and estimates)");
  show->add_option("--type", a->options.type,
                   "zv, mzv, zvd, ei, 2hump_ei, 3hump_ei, zvdd, zvddd; mzv(n=N, t=T), "
                   "ei(v_tol=V)")
      ->required();
  show->add_option("--freq-hz", a->options.freq_hz, "Shaper frequency [Hz]")->required();
  show->add_option("--damping-ratio", a->options.damping_ratio,
                   "Damping ratio the shaper is designed for, in [0, 1)")
      ->required();
  show->add_option("--residual-at-hz", a->options.residual_at_hz,
                   "Frequencies [Hz] at which to report the remaining vibration (default: the "
                   "shaper frequency)")
      ->delimiter(',');
  CLI::Option* test_dr = show->add_option(
      "--test-damping-ratio", a->test_damping_ratio,
      "Damping ratio of the vibrating mode for the residual (default: --damping-ratio)");
  CLI::Option* fw = show->add_option(
      "--firmware", a->firmware,
      "klipper or marlin (FT_MOTION): whose definition of the type (default: the type's own, "
      "Marlin's for zvdd/zvddd); the output says where the other firmware's differs");
  show->add_option("--marlin-sample-rate-hz", a->options.marlin_sample_rate_hz,
                   "Marlin's trajectory rate FTM_FS [Hz]: its impulse times are whole samples of it "
                   "(default 1000; 0: the exact times)");
  show->add_flag("--json", a->json, "Print one JSON object");
  show->callback([a, test_dr, fw] {
    shaping::ShaperReportOptions o = a->options;
    if (test_dr->count() > 0) o.test_damping_ratio = a->test_damping_ratio;
    if (fw->count() > 0) {
      try {
        o.firmware = shaping::parse_firmware(a->firmware);
      } catch (const Error& e) {
        throw Error(fmt::format("--firmware: {}", e.what()));
      }
    }
    // Each flag under its own name, by the checks Python's amctl.shaper_show makes.
    shaping::check_report_options(o, [](std::string_view key) {
      std::string flag = "--" + std::string(key);
      for (char& c : flag) c = c == '_' ? '-' : c;
      return flag;
    });
    const shaping::ShaperReport r = shaping::shaper_report(o);
    if (a->json) {
      std::cout << shaping::to_json(r).dump(2) << "\n";
    } else {
      std::cout << shaping::to_text(r);
    }
  });
}

}  // namespace amctl::cli
