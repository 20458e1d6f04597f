// amctl's steps against the step commands of Klipper's batch mode, stored by
// scripts/klipper_steps_crosscheck.py in tests/reference/klipper/klipper_steps.json (how:
// tests/reference/klipper/README.md, docs/steppers.md section 6). Klipper's first and last step
// of each stepper are stored relative to its print time of amctl's t = 0; its step compression
// moves a step earlier by at most 25 us and the clock (50 MHz) truncates.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "amctl/machine/loader.hpp"
#include "amctl/steppers/steps.hpp"

namespace amctl::steppers {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

struct FirstLast {
  double first_s = NAN;
  double last_s = NAN;
};

std::map<std::string, FirstLast> first_last_from_csv(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  std::map<std::string, FirstLast> out;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string name, time;
    std::getline(row, name, ',');
    std::getline(row, time, ',');
    FirstLast& fl = out[name];
    const double t = std::stod(time);
    if (std::isnan(fl.first_s)) fl.first_s = t;
    fl.last_s = t;
  }
  return out;
}

TEST(KlipperSteps, SyntheticFilesHaveKlippersStepCountsAndTimes) {
  std::ifstream in(kDir + "klipper_steps.json");
  ASSERT_TRUE(in) << "missing " << kDir << "klipper_steps.json";
  const auto ref = nlohmann::json::parse(in);
  const std::string csv = std::string(AMCTL_BINARY_DIR) + "/klipper_steps_test.csv";
  int files = 0;
  for (const auto& r : ref.at("results")) {
    const std::string file = r.at("file").get<std::string>();
    if (file.rfind("syn_", 0) != 0) continue;  // corpus runs need the corpus and Klipper
    const std::string cfg = r.at("cfg").get<std::string>();
    const auto m = machine::load_machine(kDir + cfg);
    const StepsReport rep = generate_steps_file(kDir + file, m, csv);
    const auto fl = first_last_from_csv(csv);
    std::remove(csv.c_str());
    const double bound_s = r.at("bound_us").get<double>() * 1e-6;
    // Times are compared where Klipper's batch run has no buffer-runout stop (README.md).
    const bool times = r.at("ok").get<bool>();
    for (const auto& s : r.at("steppers")) {
      const std::string name = s.at("stepper").get<std::string>();
      std::size_t c = 0;
      while (c < rep.motors.size() && rep.motors[c].name != name) ++c;
      ASSERT_LT(c, rep.motors.size()) << cfg << " " << file << " " << name;
      EXPECT_EQ(rep.stats[c].steps, s.at("klipper_steps").get<std::uint64_t>())
          << cfg << " " << file << " " << name;
      EXPECT_EQ(rep.stats[c].steps_positive, s.at("klipper_steps_positive").get<std::uint64_t>())
          << cfg << " " << file << " " << name;
      if (!times || rep.stats[c].steps == 0) continue;
      // Klipper's time is amctl's, or up to 25 us + a tick earlier.
      const double d_first = s.at("klipper_first_step_s").get<double>() - fl.at(name).first_s;
      const double d_last = s.at("klipper_last_step_s").get<double>() - fl.at(name).last_s;
      EXPECT_LE(std::abs(d_first), bound_s) << cfg << " " << file << " " << name;
      EXPECT_LE(std::abs(d_last), bound_s) << cfg << " " << file << " " << name;
    }
    ++files;
  }
  EXPECT_EQ(files, 14);  // 7 synthetic inputs x 2 printers
}

// Input shaping and pressure advance (klipper_steps_shaped.json: the same script on
// steps_corexy_shaped.cfg and steps_cartesian_shaped.cfg, a different shaper on X and Y and
// pressure_advance 0.04 s): with Klipper's step filter, every stepper's count, forward count,
// first and last step time of the runs without a batch-mode stop (syn_circle1000 has one, and
// the stop changes the shaped motion itself).
TEST(KlipperSteps, ShapedAndPressureAdvanceHaveKlippersStepCountsAndTimes) {
  std::ifstream in(kDir + "klipper_steps_shaped.json");
  ASSERT_TRUE(in) << "missing " << kDir << "klipper_steps_shaped.json";
  const auto ref = nlohmann::json::parse(in);
  const std::string csv = std::string(AMCTL_BINARY_DIR) + "/klipper_steps_shaped_test.csv";
  int files = 0;
  for (const auto& r : ref.at("results")) {
    if (!r.at("ok").get<bool>()) continue;
    const std::string file = r.at("file").get<std::string>();
    const std::string cfg = r.at("cfg").get<std::string>();
    const auto m = machine::load_machine(kDir + cfg);
    ASSERT_TRUE(m.input_shaper.active()) << cfg;
    ASSERT_GT(m.extruder.pressure_advance_s, 0.0) << cfg;
    const StepsReport rep = generate_steps_file(kDir + file, m, csv, StepFilter::klipper);
    const auto fl = first_last_from_csv(csv);
    std::remove(csv.c_str());
    const double bound_s = r.at("bound_us").get<double>() * 1e-6;
    for (const auto& s : r.at("steppers")) {
      const std::string name = s.at("stepper").get<std::string>();
      std::size_t c = 0;
      while (c < rep.motors.size() && rep.motors[c].name != name) ++c;
      ASSERT_LT(c, rep.motors.size()) << cfg << " " << file << " " << name;
      EXPECT_EQ(rep.stats[c].steps, s.at("klipper_steps").get<std::uint64_t>())
          << cfg << " " << file << " " << name;
      EXPECT_EQ(rep.stats[c].steps_positive, s.at("klipper_steps_positive").get<std::uint64_t>())
          << cfg << " " << file << " " << name;
      if (rep.stats[c].steps == 0) continue;
      const double d_first = s.at("klipper_first_step_s").get<double>() - fl.at(name).first_s;
      const double d_last = s.at("klipper_last_step_s").get<double>() - fl.at(name).last_s;
      EXPECT_LE(std::abs(d_first), bound_s) << cfg << " " << file << " " << name;
      EXPECT_LE(std::abs(d_last), bound_s) << cfg << " " << file << " " << name;
    }
    ++files;
  }
  // 9 synthetic inputs (2 of them changing the shaper and the pressure advance mid-print with
  // SET_INPUT_SHAPER / SET_PRESSURE_ADVANCE) x 2 printers, less the two with a stop.
  EXPECT_EQ(files, 16);
}

// generic_cartesian, polar and rotary_delta (klipper_steps_kinematics.json, the same script on
// their reference configs and synthetic files). Klipper drops a step followed within 750 us by
// one back (SDS_FILTER_TIME); amctl emits both, so its count is Klipper's plus the pairs the
// script's copy of that filter removed.
TEST(KlipperSteps, LinkageKinematicsHaveKlippersStepCountsAndTimes) {
  std::ifstream in(kDir + "klipper_steps_kinematics.json");
  ASSERT_TRUE(in) << "missing " << kDir << "klipper_steps_kinematics.json";
  const auto ref = nlohmann::json::parse(in);
  const std::string csv = std::string(AMCTL_BINARY_DIR) + "/klipper_steps_kinematics_test.csv";
  int files = 0;
  for (const auto& r : ref.at("results")) {
    const std::string file = r.at("file").get<std::string>();
    const std::string cfg = r.at("cfg").get<std::string>();
    const auto m = machine::load_machine(kDir + cfg);
    const StepsReport rep = generate_steps_file(kDir + file, m, csv);
    const auto fl = first_last_from_csv(csv);
    std::remove(csv.c_str());
    // Measured: every step within 25 us + 1 tick but one rotary delta arm step (25.048 us).
    const double bound_s = r.at("bound_us").get<double>() * 1e-6 + 0.1e-6;
    for (const auto& s : r.at("steppers")) {
      const std::string name = s.at("stepper").get<std::string>();
      std::size_t c = 0;
      while (c < rep.motors.size() && rep.motors[c].name != name) ++c;
      ASSERT_LT(c, rep.motors.size()) << cfg << " " << name;
      const auto pairs = s.at("amctl_sds_pairs_removed").get<std::uint64_t>();
      EXPECT_EQ(rep.stats[c].steps - 2 * pairs, s.at("klipper_steps").get<std::uint64_t>())
          << cfg << " " << name;
      EXPECT_EQ(rep.stats[c].steps_positive - pairs, s.at("klipper_steps_positive").get<std::uint64_t>())
          << cfg << " " << name;
      if (rep.stats[c].steps == 0) continue;
      const double d_first = s.at("klipper_first_step_s").get<double>() - fl.at(name).first_s;
      const double d_last = s.at("klipper_last_step_s").get<double>() - fl.at(name).last_s;
      EXPECT_LE(std::abs(d_first), bound_s) << cfg << " " << name;
      EXPECT_LE(std::abs(d_last), bound_s) << cfg << " " << name;
    }
    ++files;
  }
  EXPECT_EQ(files, 3);
}

}  // namespace
}  // namespace amctl::steppers
