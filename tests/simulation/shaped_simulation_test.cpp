#include "amctl/simulation/shaped_simulation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
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
               const dy::AxisModel& my, const std::vector<CommandTap>& taps, double rate = 1000.0,
               std::size_t window = 80, dy::SimulationOptions so = {}) {
  so.sample_rate_hz = rate;
  dy::MetricsOptions mo;
  ShapedRun r;
  ShapedStreamingSimulation sim(mx, my, so, mo, taps,
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
    const ShapedRun r = run_shaped(moves, belt, belt, command_taps(sx, sy, false));
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

}  // namespace
}  // namespace amctl::simulation
