#include "amctl/simulation/shaped_simulation.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/shaping/shaped_trajectory.hpp"
#include "amctl/trajectory/build.hpp"
#include "rk45.hpp"

namespace amctl::simulation {
namespace {

namespace dy = amctl::dynamics;
using VP = plan::VelocityProfile;
using trajectory::MoveSpec;

std::vector<plan::PlannedMove> corner_path(VP p = VP::trapezoid, double junction_v = 0.0) {
  const std::vector<MoveSpec> specs{{{10, 0, 0, 0}, 100.0, junction_v, 1},
                                    {{10, 10, 0, 0}, 100.0, 0.0, 2}};
  return trajectory::chain_moves({0, 0, 0, 0}, specs, 5000.0, p, 2.0e5);
}

struct ShapedRun {
  std::vector<dy::SimSample> samples;
  dy::QualityReport report;
  SmoothingFigures smoothing;
};

ShapedRun run_shaped(const std::vector<plan::PlannedMove>& moves, const dy::AxisModel& mx,
               const dy::AxisModel& my, const std::optional<shaping::Shaper>& sx,
               const std::optional<shaping::Shaper>& sy, double rate = 1000.0,
               std::size_t window = 80, dy::SimulationOptions so = {}) {
  so.sample_rate_hz = rate;
  dy::MetricsOptions mo;
  ShapedRun r;
  ShapedStreamingSimulation sim(mx, my, so, mo, sx, sy,
                                [&](const dy::SimSample& s, double) { r.samples.push_back(s); }, window);
  for (const auto& m : moves) sim.push(m);
  r.report = sim.finish();
  r.smoothing = sim.smoothing();
  return r;
}

// Reference: the belt ODE x'' = -2 z w (x' - u') - w^2 (x - u) per axis, integrated with
// Dormand-Prince 5(4) (tests/dynamics/rk45.hpp) with u the explicitly shaped command
// sum_i a_i x(t - d_i) evaluated on the plan (random access), between every shifted piece
// boundary.
std::vector<testing::State4> reference(const std::vector<plan::PlannedMove>& moves, double w,
                                       double z, const shaping::Shaper& sx,
                                       const shaping::Shaper& sy, const std::vector<double>& times) {
  const trajectory::Trajectory tr(moves);
  const shaping::AppliedPulses px = shaping::applied_pulses(sx), py = shaping::applied_pulses(sy);
  std::vector<double> bp;
  for (const auto& m : moves) {
    std::array<plan::PathPiece, 7> pieces;
    const std::size_t n = trajectory::move_pieces(m, pieces);
    std::vector<double> b{m.start_time_s};
    double t = m.start_time_s;
    for (std::size_t i = 0; i < n; ++i) b.push_back(t += pieces[i].duration_s);
    for (double d : px.delays_s) for (double x : b) bp.push_back(x + d);
    for (double d : py.delays_s) for (double x : b) bp.push_back(x + d);
  }
  std::sort(bp.begin(), bp.end());
  double lo = 0, hi = 0;
  auto shaped = [&](double t) {
    const double eps = 4e-15 * std::max(1.0, std::abs(t));
    const double tt = std::clamp(t, lo + eps, hi - eps);
    std::array<double, 4> u{};  // x, x', y, y'
    for (std::size_t i = 0; i < px.weights.size(); ++i) {
      const auto s = tr.evaluate(tt - px.delays_s[i]);
      u[0] += px.weights[i] * s.pos_mm[0];
      u[1] += px.weights[i] * s.vel_mm_s[0];
    }
    for (std::size_t i = 0; i < py.weights.size(); ++i) {
      const auto s = tr.evaluate(tt - py.delays_s[i]);
      u[2] += py.weights[i] * s.pos_mm[1];
      u[3] += py.weights[i] * s.vel_mm_s[1];
    }
    return u;
  };
  auto f = [&](double t, const testing::State4& x) {
    const auto u = shaped(t);
    return testing::State4{x[1], -2 * z * w * (x[1] - u[1]) - w * w * (x[0] - u[0]), x[3],
                           -2 * z * w * (x[3] - u[3]) - w * w * (x[2] - u[2])};
  };
  const double t_begin = bp.front() - 1e-3;
  const auto s0 = tr.evaluate(moves.front().start_time_s);
  std::vector<testing::State4> out;
  testing::State4 y{s0.pos_mm[0], 0.0, s0.pos_mm[1], 0.0};
  double tc = t_begin;
  std::size_t b = 0;
  for (double tq : times) {  // increasing
    while (tc < tq) {
      while (b < bp.size() && bp[b] <= tc) ++b;
      const double e = b < bp.size() ? std::min(bp[b], tq) : tq;
      lo = tc;
      hi = e;
      y = testing::dopri5(f, tc, e, y);
      tc = e;
    }
    out.push_back(y);
  }
  return out;
}

double residual_after(const std::vector<dy::SimSample>& samples, double t_after) {
  double worst = 0.0;
  for (const auto& s : samples) {
    if (s.t_s >= t_after) worst = std::max(worst, std::hypot(s.vibration_mm[0], s.vibration_mm[1]));
  }
  return worst;
}

TEST(ShapedSimulate, EqualsRk45OnTheExplicitlyShapedCommand) {
  const double f = 40.0, z = 0.05, w = 2 * std::numbers::pi * f;
  const auto belt = dy::AxisModel::belt(f, z);
  struct Case {
    VP profile;
    double junction_v;
    const char* sx;
    double fx;
    const char* sy;
    double fy;
  };
  for (const Case& c : {Case{VP::trapezoid, 0.0, "zv", 40.0, "zv", 40.0},
                        Case{VP::trapezoid, 20.0, "mzv", 35.0, "ei", 50.0},
                        Case{VP::scurve7, 20.0, "2hump_ei", 45.0, "zvd", 33.0}}) {
    const auto moves = corner_path(c.profile, c.junction_v);
    const auto sx = shaping::make_shaper(c.sx, c.fx, 0.1);
    const auto sy = shaping::make_shaper(c.sy, c.fy, 0.1);
    const ShapedRun r = run_shaped(moves, belt, belt, sx, sy);
    std::vector<double> times;
    std::vector<std::size_t> idx;
    for (std::size_t k = 0; k < r.samples.size(); k += 7) {
      times.push_back(r.samples[k].t_s);
      idx.push_back(k);
    }
    const auto ref = reference(moves, w, z, sx, sy, times);
    double worst = 0.0;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const auto& s = r.samples[idx[i]];
      worst = std::max({worst, std::abs(s.sim_mm[0] - ref[i][0]), std::abs(s.sim_mm[1] - ref[i][2])});
    }
    EXPECT_LT(worst, 1e-6) << c.sx << "/" << c.sy;
    EXPECT_GT(idx.size(), 50u);
  }
}


std::vector<dy::SimSample> run_plain(const std::vector<plan::PlannedMove>& moves, const dy::AxisModel& mx,
                                     const dy::AxisModel& my, double rate = 1000.0) {
  dy::SimulationOptions o;
  o.sample_rate_hz = rate;
  o.vibration_per_sample = true;
  std::vector<dy::SimSample> out;
  (void)dy::simulate(moves, mx, my, o, [&](const dy::SimSample& s) { out.push_back(s); });
  return out;
}

TEST(ShapedSimulate, WithoutShaperEqualsThePlainSimulation) {
  const auto moves = corner_path(VP::scurve7, 30.0);
  const auto belt = dy::AxisModel::belt(37.0, 0.07);
  const ShapedRun r = run_shaped(moves, belt, belt, std::nullopt, std::nullopt);
  const auto plain = run_plain(moves, belt, belt);
  ASSERT_GE(r.samples.size(), plain.size());
  for (std::size_t k = 0; k < plain.size(); ++k) {
    EXPECT_EQ(r.samples[k].t_s, plain[k].t_s);
    // The plan's pieces through the plant engine against dynamics::Simulator on the moves:
    // two exact computations, equal up to round-off.
    EXPECT_NEAR(r.samples[k].sim_mm[0], plain[k].sim_mm[0], 1e-12);
    EXPECT_NEAR(r.samples[k].sim_mm[1], plain[k].sim_mm[1], 1e-12);
    EXPECT_EQ(r.samples[k].cmd_mm, plain[k].cmd_mm);
    EXPECT_NEAR(r.samples[k].vibration_mm[0], plain[k].vibration_mm[0], 1e-12);
  }
  EXPECT_LT(r.smoothing.max_mm, 1e-12);
}

TEST(ShapedSimulate, StreamingWindowDoesNotChangeThePath) {
  // 1500 short zigzag moves (0.2-2 mm at up to 150 mm/s): many moves per shaper duration.
  std::vector<MoveSpec> specs;
  double x = 0, y = 0;
  for (int i = 0; i < 1500; ++i) {
    const double len = 0.2 + 1.8 * ((i * 7919) % 97) / 96.0;
    const double ang = ((i * 104729) % 360) * std::numbers::pi / 180.0;
    x += len * std::cos(ang);
    y += len * std::sin(ang);
    specs.push_back({{x, y, 0, 0.01 * i}, 150.0, (i % 5) * 5.0, static_cast<std::uint64_t>(i + 1), i / 100});
  }
  specs.back().end_v_mm_s = 0.0;
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 4000.0, VP::trapezoid);
  const auto belt = dy::AxisModel::belt(30.0, 0.08);
  const auto sx = shaping::make_shaper("ei", 25.0, 0.1);
  const auto sy = shaping::make_shaper("mzv", 45.0, 0.1);
  const ShapedRun a = run_shaped(moves, belt, belt, sx, sy, 1000.0, 80);
  const ShapedRun b = run_shaped(moves, belt, belt, sx, sy, 1000.0, 1000000);
  ASSERT_EQ(a.samples.size(), b.samples.size());
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    // The plant engine sees the same shaped pieces whatever the window; the metrics' plan
    // cursor restarts with each window.
    ASSERT_NEAR(a.samples[k].sim_mm[0], b.samples[k].sim_mm[0], 1e-12) << k;
    ASSERT_NEAR(a.samples[k].sim_mm[1], b.samples[k].sim_mm[1], 1e-12) << k;
    ASSERT_NEAR(a.samples[k].vibration_mm[0], b.samples[k].vibration_mm[0], 1e-12) << k;
    ASSERT_NEAR(a.samples[k].vibration_mm[1], b.samples[k].vibration_mm[1], 1e-12) << k;
    ASSERT_EQ(a.samples[k].move_index, b.samples[k].move_index) << k;
  }
  EXPECT_NEAR(a.report.max_contour_error_mm, b.report.max_contour_error_mm, 1e-12);
  EXPECT_NEAR(a.report.max_residual_vibration_mm, b.report.max_residual_vibration_mm, 1e-12);
  EXPECT_NEAR(a.smoothing.max_mm, b.smoothing.max_mm, 1e-12);
  EXPECT_NEAR(a.smoothing.max_at_corners_mm, b.smoothing.max_at_corners_mm, 1e-12);
  EXPECT_GT(a.smoothing.max_mm, 0.0);
}

TEST(ShapedSimulate, ZvAtTheBeltFrequencyRemovesTheResidualVibration) {
  // Belt 40 Hz, zeta 0.05; ZV designed for exactly that mode. After the corner (full stop)
  // and after the end the unshaped nozzle rings; the shaped one does not.
  const double f = 40.0, z = 0.05;
  const auto belt = dy::AxisModel::belt(f, z);
  const auto moves = corner_path();
  const auto zv = shaping::make_shaper("zv", f, z);
  const ShapedRun with = run_shaped(moves, belt, belt, zv, zv);
  const ShapedRun without = run_shaped(moves, belt, belt, std::nullopt, std::nullopt);
  EXPECT_GT(without.report.max_residual_vibration_mm, 0.05);
  EXPECT_LT(with.report.max_residual_vibration_mm, 0.05 * without.report.max_residual_vibration_mm);
  EXPECT_LT(with.report.max_residual_vibration_mm, 1e-9);
  // After the shaped motion has ended, sample by sample.
  const double t_end = moves.back().end_time_s() + applied_pulses(zv).delays_s.back();
  EXPECT_LT(residual_after(with.samples, t_end), 0.05 * residual_after(without.samples, t_end));
  // The ringing is gone; the corner is rounded instead.
  EXPECT_LT(with.report.max_corner_overshoot_mm, 0.05 * without.report.max_corner_overshoot_mm);
  EXPECT_GT(with.smoothing.max_mm, 0.01);
  EXPECT_EQ(with.smoothing.max_at_corners_mm, with.smoothing.max_mm);
}

TEST(ShapedSimulate, ConstantVelocityIsLeftAsPlanned) {
  // One long straight move: during the cruise the shaped command is the plan, so once the
  // start transient has decayed the shaped and unshaped nozzles both sit on the plan.
  const std::vector<MoveSpec> specs{{{300, 150, 0, 0}, 200.0, 0.0, 1}};
  const auto moves = trajectory::chain_moves({0, 0, 0, 0}, specs, 5000.0, VP::trapezoid);
  const auto belt = dy::AxisModel::belt(40.0, 0.1);
  const auto mzv = shaping::make_shaper("mzv", 40.0, 0.1);
  const ShapedRun r = run_shaped(moves, belt, belt, mzv, mzv);
  const double t_a = moves[0].start_time_s + moves[0].accel_t_s + 0.5;
  const double t_b = moves[0].start_time_s + moves[0].accel_t_s + moves[0].cruise_t_s - 0.05;
  ASSERT_GT(t_b, t_a + 0.2);
  int n = 0;
  for (const auto& s : r.samples) {
    if (s.t_s < t_a || s.t_s > t_b) continue;
    EXPECT_NEAR(s.sim_mm[0], s.cmd_mm[0], 1e-9);
    EXPECT_NEAR(s.sim_mm[1], s.cmd_mm[1], 1e-9);
    ++n;
  }
  EXPECT_GT(n, 200);
  EXPECT_LT(r.smoothing.max_mm, 1e-9);  // a straight line: the shaped command stays on it
}

// Reference in corexy motor space: motor j (A = X + Y, B = X - Y) follows the belt ODE of
// its own model, m'' = -2 z_j w_j (m' - u_j') - w_j^2 (m - u_j), driven by the motor command
// u_j = row_j . (X_s, Y_s) of the explicitly shaped cartesian command (X shaped by sx, Y by
// sy), integrated with Dormand-Prince 5(4) between every shifted piece boundary; the nozzle
// is X = (A + B) / 2, Y = (A - B) / 2.
std::vector<std::array<double, 2>> reference_corexy(const std::vector<plan::PlannedMove>& moves,
                                                    std::array<double, 2> w, std::array<double, 2> z,
                                                    const shaping::Shaper& sx, const shaping::Shaper& sy,
                                                    const std::vector<double>& times) {
  const trajectory::Trajectory tr(moves);
  const shaping::AppliedPulses px = shaping::applied_pulses(sx), py = shaping::applied_pulses(sy);
  std::vector<double> bp;
  for (const auto& m : moves) {
    std::array<plan::PathPiece, 7> pieces;
    const std::size_t n = trajectory::move_pieces(m, pieces);
    std::vector<double> b{m.start_time_s};
    double t = m.start_time_s;
    for (std::size_t i = 0; i < n; ++i) b.push_back(t += pieces[i].duration_s);
    for (double d : px.delays_s) for (double x : b) bp.push_back(x + d);
    for (double d : py.delays_s) for (double x : b) bp.push_back(x + d);
  }
  std::sort(bp.begin(), bp.end());
  double lo = 0, hi = 0;
  auto motor_command = [&](double t) {
    const double eps = 4e-15 * std::max(1.0, std::abs(t));
    const double tt = std::clamp(t, lo + eps, hi - eps);
    std::array<double, 4> c{};  // X_s, X_s', Y_s, Y_s'
    for (std::size_t i = 0; i < px.weights.size(); ++i) {
      const auto s = tr.evaluate(tt - px.delays_s[i]);
      c[0] += px.weights[i] * s.pos_mm[0];
      c[1] += px.weights[i] * s.vel_mm_s[0];
    }
    for (std::size_t i = 0; i < py.weights.size(); ++i) {
      const auto s = tr.evaluate(tt - py.delays_s[i]);
      c[2] += py.weights[i] * s.pos_mm[1];
      c[3] += py.weights[i] * s.vel_mm_s[1];
    }
    return std::array<double, 4>{c[0] + c[2], c[1] + c[3], c[0] - c[2], c[1] - c[3]};  // A, A', B, B'
  };
  auto f = [&](double t, const testing::State4& x) {
    const auto u = motor_command(t);
    return testing::State4{x[1], -2 * z[0] * w[0] * (x[1] - u[1]) - w[0] * w[0] * (x[0] - u[0]), x[3],
                           -2 * z[1] * w[1] * (x[3] - u[3]) - w[1] * w[1] * (x[2] - u[2])};
  };
  const auto s0 = tr.evaluate(moves.front().start_time_s);
  testing::State4 y{s0.pos_mm[0] + s0.pos_mm[1], 0.0, s0.pos_mm[0] - s0.pos_mm[1], 0.0};
  std::vector<std::array<double, 2>> out;
  double tc = bp.front() - 1e-3;
  std::size_t b = 0;
  for (double tq : times) {
    while (tc < tq) {
      while (b < bp.size() && bp[b] <= tc) ++b;
      const double e = b < bp.size() ? std::min(bp[b], tq) : tq;
      lo = tc;
      hi = e;
      y = testing::dopri5(f, tc, e, y);
      tc = e;
    }
    out.push_back({0.5 * (y[0] + y[2]), 0.5 * (y[0] - y[2])});
  }
  return out;
}

TEST(ShapedSimulate, MotorSpaceWithTheSameShaperEqualsCartesian) {
  const auto a = shaping::make_shaper("mzv", 40.0, 0.1);
  // corexy motors with the same shaper: the nozzle equals the Cartesian run (the motor map
  // is linear and the same belt on both motors; here equal models on X and Y).
  const auto belt = dy::AxisModel::belt(40.0, 0.1);
  const auto moves = corner_path(VP::trapezoid, 10.0);
  dy::SimulationOptions so;
  so.motor_rows = {{{1.0, 1.0, 0.0}, {1.0, -1.0, 0.0}}};  // CoreXY A = X + Y, B = X - Y
  so.motor_space = true;
  const ShapedRun m = run_shaped(moves, belt, belt, a, a, 1000.0, 80, so);
  const ShapedRun c = run_shaped(moves, belt, belt, a, a);
  ASSERT_EQ(m.samples.size(), c.samples.size());
  for (std::size_t k = 0; k < m.samples.size(); ++k) {
    EXPECT_NEAR(m.samples[k].sim_mm[0], c.samples[k].sim_mm[0], 1e-9);
    EXPECT_NEAR(m.samples[k].sim_mm[1], c.samples[k].sim_mm[1], 1e-9);
  }
}

TEST(ShapedSimulate, MotorSpaceDifferentShapersEqualRk45OnTheExplicitlyShapedCommand) {
  const std::array<double, 2> f{40.0, 55.0}, z{0.05, 0.08};
  const std::array<double, 2> w{2 * std::numbers::pi * f[0], 2 * std::numbers::pi * f[1]};
  const auto ma = dy::AxisModel::belt(f[0], z[0]), mb = dy::AxisModel::belt(f[1], z[1]);
  dy::SimulationOptions so;
  so.motor_rows = {{{1.0, 1.0, 0.0}, {1.0, -1.0, 0.0}}};  // CoreXY A = X + Y, B = X - Y
  so.motor_space = true;
  struct Case {
    VP profile;
    double junction_v;
    const char* sx;
    double fx;
    const char* sy;
    double fy;
  };
  for (const Case& c : {Case{VP::trapezoid, 0.0, "zv", 40.0, "mzv", 55.0},
                        Case{VP::trapezoid, 20.0, "mzv", 35.0, "ei", 50.0},
                        Case{VP::scurve7, 20.0, "2hump_ei", 45.0, "zvd", 33.0}}) {
    const auto moves = corner_path(c.profile, c.junction_v);
    const auto sx = shaping::make_shaper(c.sx, c.fx, 0.1);
    const auto sy = shaping::make_shaper(c.sy, c.fy, 0.1);
    const ShapedRun r = run_shaped(moves, ma, mb, sx, sy, 1000.0, 80, so);
    std::vector<double> times;
    std::vector<std::size_t> idx;
    for (std::size_t k = 0; k < r.samples.size(); k += 7) {
      times.push_back(r.samples[k].t_s);
      idx.push_back(k);
    }
    const auto ref = reference_corexy(moves, w, z, sx, sy, times);
    double worst = 0.0;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const auto& s = r.samples[idx[i]];
      worst = std::max({worst, std::abs(s.sim_mm[0] - ref[i][0]), std::abs(s.sim_mm[1] - ref[i][1])});
    }
    std::printf("corexy %s %.0f Hz on X, %s %.0f Hz on Y: worst %.3g mm over %zu samples\n", c.sx, c.fx, c.sy,
                c.fy, worst, idx.size());
    EXPECT_LT(worst, 1e-6) << c.sx << "/" << c.sy;
    EXPECT_GT(idx.size(), 50u);
  }
}

TEST(ShapedSimulate, ShaperSettingsAreChecked) {
  AxisShaperSetting s{"mzv", 40.0, 0.1, "test"};
  EXPECT_NO_THROW((void)make_axis_shaper(s, 1000.0));
  auto msg = [&](AxisShaperSetting bad) {
    try {
      (void)make_axis_shaper(bad, 1000.0);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(msg({"bogus", 40.0, 0.1, "t"}).find("--shaper"), std::string::npos);
  EXPECT_NE(msg({"zv", 0.0, 0.1, "t"}).find("--shaper-freq-hz"), std::string::npos);
  EXPECT_NE(msg({"zv", -3.0, 0.1, "t"}).find("--shaper-freq-hz"), std::string::npos);
  EXPECT_NE(msg({"zv", 500.0, 0.1, "t"}).find("Nyquist"), std::string::npos);
  EXPECT_NE(msg({"zv", 40.0, 1.0, "t"}).find("--shaper-damping-ratio"), std::string::npos);
}


TEST(ShapedSimulate, EachFirmwaresDefinitionIsApplied) {
  // Marlin's FT_MOTION MZV (asked for): K instead of K^(3/4), on the 1 kHz grid.
  AxisShaperSetting s{"mzv", 40.0, 0.1, "t"};
  apply_requested_firmware(shaping::Firmware::marlin, s);
  const shaping::Shaper m = make_axis_shaper(s, 1000.0);
  const double K = std::exp(-0.1 * std::numbers::pi / std::sqrt(1.0 - 0.01));
  EXPECT_NEAR(m.amplitudes[2] / m.amplitudes[0], K * K, 1e-14);
  EXPECT_DOUBLE_EQ(m.times_s[1], 0.009);
  // A type Marlin lacks is refused, naming the parameter and both firmwares' types.
  AxisShaperSetting g{"mzv(n=4, t=0.9)", 40.0, 0.1, "t"};
  apply_requested_firmware(shaping::Firmware::marlin, g);
  try {
    (void)make_axis_shaper(g, 1000.0);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--shaper"), std::string::npos) << e.what();
  }
  // A Marlin machine's ZV is Marlin's stepper ZV (exact times); its MZV stays Klipper's
  // (Prusa's Marlin-derived firmware runs Klipper's definitions).
  machine::Machine mm;
  mm.firmware = machine::Firmware::marlin;
  AxisShaperSetting zv{"zv", 40.0, 0.1, "t"}, mzv{"mzv", 40.0, 0.1, "t"};
  apply_machine_firmware(mm, zv);
  apply_machine_firmware(mm, mzv);
  EXPECT_EQ(zv.firmware, shaping::Firmware::marlin);
  EXPECT_EQ(zv.marlin_sample_rate_hz, 0.0);
  EXPECT_EQ(mzv.firmware, shaping::Firmware::klipper);
  // M593 is Marlin's (ZV).
  const std::string path = std::string(AMCTL_SOURCE_DIR) + "/tests/simulation/m593_corner.gcode";
  const ShaperSettings ms = shapers_from_m593(m593_before_first_move(path, machine::Machine{}));
  ASSERT_TRUE(ms.x);
  EXPECT_EQ(ms.x->firmware, shaping::Firmware::marlin);
  // --shaper-firmware applies to every shaper in use, whatever its source.
  ShaperRequest req;
  req.firmware = shaping::Firmware::marlin;
  const ShaperSettings rs = resolve_shapers(req, machine::Machine{}, path);
  ASSERT_TRUE(rs.x);
  EXPECT_EQ(rs.x->marlin_sample_rate_hz, shaping::kMarlinFtmSampleRateHz);
  req.none = true;
  EXPECT_THROW((void)resolve_shapers(req, machine::Machine{}, path), Error);
}


struct ShapingCapture final : gcode::EventSink {
  std::vector<gcode::InputShapingCommand> cmds;
  void on_move(const gcode::MoveRequest&) override {}
  void on_input_shaping(const gcode::InputShapingCommand& c) override { cmds.push_back(c); }
};

TEST(ShapedSimulate, InterpreterReportsM593AndStillCountsItAsIgnored) {
  gcode::Interpreter in({}, "t.gcode");
  ShapingCapture sink;
  in.feed("M593 F40 D0.07", 1, sink);
  in.feed("M593 X F35", 2, sink);
  in.feed("M593 Y D0.2 T1", 3, sink);
  ASSERT_EQ(sink.cmds.size(), 3u);
  EXPECT_TRUE(sink.cmds[0].x && sink.cmds[0].y);
  EXPECT_EQ(sink.cmds[0].freq_hz, 40.0);
  EXPECT_EQ(sink.cmds[0].damping_ratio, 0.07);
  EXPECT_TRUE(sink.cmds[1].x && !sink.cmds[1].y);
  EXPECT_EQ(sink.cmds[1].freq_hz, 35.0);
  EXPECT_FALSE(sink.cmds[1].damping_ratio.has_value());
  EXPECT_TRUE(!sink.cmds[2].x && sink.cmds[2].y);
  EXPECT_EQ(sink.cmds[2].type, 1.0);
  EXPECT_EQ(sink.cmds[2].line, 3u);
  EXPECT_EQ(in.ignored_commands().at("M593"), 3u);  // as before: estimate output unchanged
  EXPECT_TRUE(in.unknown_commands().empty());
}

TEST(ShapedSimulate, M593FollowsMarlinsRules) {
  auto cmd = [](bool x, bool y, std::optional<double> f, std::optional<double> d, std::uint64_t line) {
    gcode::InputShapingCommand c;
    c.x = x;
    c.y = y;
    c.freq_hz = f;
    c.damping_ratio = d;
    c.line = line;
    return c;
  };
  // F for both, then X's damping; Marlin's default zeta 0.15 where D never came.
  std::vector<gcode::InputShapingCommand> a{cmd(true, true, 40.0, std::nullopt, 3),
                                            cmd(true, false, std::nullopt, 0.05, 4)};
  ShaperSettings s = shapers_from_m593(a);
  ASSERT_TRUE(s.x && s.y);
  EXPECT_EQ(s.x->type, "zv");
  EXPECT_EQ(s.x->freq_hz, 40.0);
  EXPECT_EQ(s.x->damping_ratio, 0.05);
  EXPECT_EQ(s.y->damping_ratio, 0.15);
  EXPECT_EQ(s.x->source, "M593 line 4");
  EXPECT_TRUE(s.warnings.empty());
  // F0 turns an axis off; out-of-range values are rejected with a warning, as Marlin does.
  std::vector<gcode::InputShapingCommand> b{cmd(true, true, 40.0, 0.1, 1), cmd(false, true, 0.0, std::nullopt, 2),
                                            cmd(true, true, -3.0, 1.5, 3)};
  s = shapers_from_m593(b);
  ASSERT_TRUE(s.x.has_value());
  EXPECT_FALSE(s.y.has_value());
  EXPECT_EQ(s.x->freq_hz, 40.0);
  EXPECT_EQ(s.x->damping_ratio, 0.1);
  EXPECT_EQ(s.warnings.size(), 2u);
  // Damping without a frequency: not shaped, with a warning.
  std::vector<gcode::InputShapingCommand> c{cmd(true, true, std::nullopt, 0.1, 1)};
  s = shapers_from_m593(c);
  EXPECT_FALSE(s.any());
  EXPECT_EQ(s.warnings.size(), 2u);
}

TEST(ShapedSimulate, M593BeforeTheFirstMoveIsFoundAndLaterOnesAreWarned) {
  const std::string path = std::string(AMCTL_SOURCE_DIR) + "/tests/simulation/m593_corner.gcode";
  machine::Machine m;
  const auto before = m593_before_first_move(path, m);
  ASSERT_EQ(before.size(), 1u);
  EXPECT_EQ(before[0].line, 3u);
  const ShaperSettings s = shapers_from_m593(before);
  ASSERT_TRUE(s.x && s.y);
  dy::PrintSimulationOptions o;
  o.metrics.keep_per_move = false;
  const auto belt = dy::AxisModel::belt(40.0, 0.05);
  const ShapedPrintResult r = simulate_shaped_print(path, m, belt, belt, o, s);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("line 6"), std::string::npos);
  EXPECT_LT(r.shaped.report.max_residual_vibration_mm, 0.05 * r.without.report.max_residual_vibration_mm);
}

}  // namespace
}  // namespace amctl::simulation
