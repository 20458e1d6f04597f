// The studies behind `amctl thermal ...`: they must give what the underlying models give,
// write the documented CSV layouts, and follow the JSON convention (non-finite -> null).
#include "amctl/thermal/studies.hpp"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::thermal {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<std::string> read_lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  return lines;
}

std::string temp_path(const char* name) {
  return ::testing::TempDir() + "amctl_studies_test_" + name;
}

TEST(MarginStudy, GivesComputeMarginsOfTheSamePlantAndPi) {
  MarginStudyOptions o;
  o.length_m = 2e-4;
  o.modes = 2;
  const MarginStudy s = run_margin_study(o);
  const MarginReport r =
      compute_margins(PowderBedTf(o.material, 2e-4), control::PidGains::standard(0.3, 0.5), 2);
  EXPECT_EQ(s.report.margin_on_gn_sweep, r.margin_on_gn_sweep);
  EXPECT_EQ(s.report.margin_on_g_hamiltonian, r.margin_on_g_hamiltonian);
  const Json j = to_json(s);
  EXPECT_EQ(j.at("margin_on_GN").get<double>(), r.margin_on_gn_sweep);
  EXPECT_EQ(j.at("modes").get<int>(), 2);
  EXPECT_EQ(j.at("poles_rad_s").size(), 4u);  // k = 0 .. max(3, N)
  EXPECT_EQ(j.at("zeros_rad_s").size(), 3u);  // k = 0 .. max(2, N - 1)
  EXPECT_DOUBLE_EQ(j.at("high_frequency_ceiling_1_over_kp").get<double>(), 1.0 / 0.3);
}

TEST(MarginStudy, NonFiniteFiguresBecomeNullNotStrings) {
  MarginStudy s = run_margin_study(MarginStudyOptions{});
  s.report.peak_omega_gn = kInf;  // the sup of |C S| at w -> inf
  s.report.margin_on_g_sweep = std::nan("");
  const Json j = to_json(s);
  EXPECT_TRUE(j.at("peak_omega_GN_rad_s").is_null());
  EXPECT_TRUE(j.at("margin_on_G").is_null());
  EXPECT_TRUE(j.at("margin_on_GN").is_number());
}

TEST(MarginStudy, RejectsBadOptionsNamingThem) {
  auto message = [](MarginStudyOptions o) -> std::string {
    try {
      (void)run_margin_study(o);
    } catch (const Error& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected amctl::Error";
    return "";
  };
  MarginStudyOptions o;
  o.ti_s = 0.0;
  EXPECT_NE(message(o).find("Ti (PI integral time)"), std::string::npos);
  o = MarginStudyOptions{};
  o.kp_w_m2k = -1.0;
  EXPECT_NE(message(o).find("kp"), std::string::npos);
  o = MarginStudyOptions{};
  o.length_m = 0.0;
  EXPECT_NE(message(o).find("length_m"), std::string::npos);
  o = MarginStudyOptions{};
  o.modes = 0;
  EXPECT_NE(message(o).find("modes"), std::string::npos);
}

TEST(MarginStudy, BodeCsvHasAHeaderAndOneRowPerFrequency) {
  const std::string path = temp_path("bode.csv");
  write_bode_csv(path, PowderBedTf(PowderMaterial{}, 1e-4), 1);
  const auto lines = read_lines(path);
  ASSERT_EQ(lines.size(), 402u);
  EXPECT_EQ(lines[0], "omega_rad_s,mag_G_db,phase_G_deg,mag_GN_db,phase_GN_deg");
  EXPECT_EQ(lines[1].rfind("0.0001,", 0), 0u) << lines[1];
  std::remove(path.c_str());
  EXPECT_THROW(write_bode_csv("/nonexistent-dir/x.csv", PowderBedTf(PowderMaterial{}, 1e-4), 1),
               Error);
}

TEST(SlsRun, AppliesTheOverridesAndWritesTheTrace) {
  SlsRunOptions o;
  o.config_path = AMCTL_SOURCE_DIR "/configs/sls_pa12.toml";
  o.layers_added = 3;
  o.anti_windup = control::AntiWindup::conditional_integration;
  const SlsRun run = run_sls_build(o);
  EXPECT_EQ(run.config.layers_added, 3);
  EXPECT_EQ(run.config.anti_windup, control::AntiWindup::conditional_integration);
  EXPECT_EQ(run.result.layers.size(), 4u);  // the start-up interval and three additions
  ASSERT_FALSE(run.result.trace.empty());
  const Json j = to_json(run);
  EXPECT_EQ(j.at("anti_windup").get<std::string>(), "conditional_integration");
  EXPECT_EQ(j.at("layers_added").get<int>(), 3);
  EXPECT_EQ(j.at("steps").get<std::int64_t>(), run.result.steps);
  const std::string path = temp_path("sls.csv");
  write_sls_trace_csv(path, run.result);
  const auto lines = read_lines(path);
  EXPECT_EQ(lines.size(), run.result.trace.size() + 1);
  EXPECT_EQ(lines[0],
            "t_s,layers,depth_m,y_c,setpoint_c,flux_w_m2,disturbance_w_m2,integral_w_m2");
  std::remove(path.c_str());
  o.trace = false;
  EXPECT_TRUE(run_sls_build(o).result.trace.empty());
}

TEST(HeaterStudy, HotendComparesTheTunedPidWithTheIdentifiedMpc) {
  const HeaterStudy s = run_heater_study(HeaterStudyOptions::hotend());
  ASSERT_EQ(s.runs.size(), 2u);  // classic_zn is the chosen rule: no second PID
  EXPECT_EQ(s.runs[0].controller, "PID classic_zn");
  EXPECT_EQ(s.runs[1].controller, "MPC identified");
  EXPECT_TRUE(s.autotune.ok);
  // The same run as the library pieces assembled by hand (the study adds nothing of its own).
  control::PidController pid(s.autotune.gains, heater_pid_options());
  const auto by_hand = run_heater_scenario(
      s.options.plant, s.scenario,
      [&](double t, double y, double, double, double dt) { return pid.update(t, y, dt); }, "pid");
  EXPECT_EQ(by_hand.energy_j, s.runs[0].energy_j);
  EXPECT_EQ(by_hand.flow_ripple_k, s.runs[0].flow_ripple_k);

  HeaterStudy never = s;
  never.runs[0].heat_up_time_s = kInf;  // never within 1 K of the target
  const Json j = to_json(never);
  EXPECT_TRUE(j.at("runs").at(0).at("heat_up_time_s").is_null());
  EXPECT_TRUE(j.at("runs").at(1).at("heat_up_time_s").is_number());
  EXPECT_EQ(j.at("heater").get<std::string>(), "hotend");
  EXPECT_DOUBLE_EQ(j.at("autotune").at("marlin_kp").get<double>(), 255 * s.autotune.gains.kp());

  const std::string path = temp_path("heater.csv");
  write_heater_traces_csv(path, s);
  const auto lines = read_lines(path);
  EXPECT_EQ(lines[0],
            "t_s,PID classic_zn_c,PID classic_zn_duty,MPC identified_c,MPC identified_duty");
  EXPECT_EQ(lines.size(), s.runs[0].t_s.size() + 1);
  std::remove(path.c_str());
}

TEST(HeaterStudy, AnotherRuleAddsTheClassicPidForComparison) {
  HeaterStudyOptions o = HeaterStudyOptions::hotend();
  o.rule = TuningRule::some_overshoot;
  const HeaterStudy s = run_heater_study(o);
  ASSERT_EQ(s.runs.size(), 3u);
  EXPECT_EQ(s.runs[0].controller, "PID some_overshoot");
  EXPECT_EQ(s.runs[1].controller, "PID classic_zn");
}

TEST(HeaterStudy, RejectsBadOptions) {
  HeaterStudyOptions o = HeaterStudyOptions::hotend();
  o.target_c = 30.0;  // less than 20 K above the 25 C ambient
  EXPECT_THROW((void)run_heater_study(o), Error);
  o = HeaterStudyOptions::hotend();
  o.cycles = 2;
  EXPECT_THROW((void)run_heater_study(o), Error);
  o = HeaterStudyOptions::hotend();
  o.sensor_noise_k = -0.1;
  EXPECT_THROW((void)run_heater_study(o), Error);
  o = HeaterStudyOptions::bed_defaults();
  o.plant.block_capacity_j_k = 0.0;
  EXPECT_THROW((void)run_heater_study(o), Error);
  EXPECT_EQ(tuning_rule_from_string("no_overshoot"), TuningRule::no_overshoot);
  EXPECT_FALSE(tuning_rule_from_string("zn").has_value());
}

}  // namespace
}  // namespace amctl::thermal
