// The plant engine against independent references: closed-form step and ramp responses of a
// second-order mode, and an adaptive Dormand-Prince integration of the physical ODE
// x'' = -2 z w (x' - x_b') - w^2 (x - x_b) (position and velocity of the command as input,
// no matrix exponential, no modal coordinates).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/dynamics/plant.hpp"
#include "rk45.hpp"

namespace amctl::dynamics {
namespace {

constexpr double kPi = std::numbers::pi;

struct Collected {
  std::vector<PlantSample> s;
  std::vector<std::array<double, 2>> vib;
};

// Constant acceleration a from rest on axis 0 (x_b = a t^2 / 2), one mode (f, z, g):
// e'' + 2 z w e' + w^2 e = -g a, e(0) = e'(0) = 0:
//   e(t) = -(g a / w^2) [1 - exp(-z w t) (cos(wd t) + (z w / wd) sin(wd t))].
TEST(ModalPlant, RampResponseMatchesClosedForm) {
  const double f = 23.0, z = 0.07, g = 0.8, a = 3000.0;
  const AxisModel m = AxisModel::from_modes({Mode{f, z, g}});
  const double w = 2 * kPi * f, wd = w * std::sqrt(1 - z * z);
  // The grid is not aligned with the pieces (partial steps at every boundary).
  PieceSimulator sim(m, AxisModel::rigid(), 1000.0, -0.00037);
  CommandPiece p;
  p.t0_s = 0.0;
  p.duration_s = 0.2;
  p.c[0][2] = a / 2;
  Collected c;
  sim.push(p, [&](const PlantSample& s) { c.s.push_back(s); });
  ASSERT_GT(c.s.size(), 150u);
  double worst = 0.0;
  for (const PlantSample& s : c.s) {
    const double t = s.t_s;
    const double e = t <= 0 ? 0.0
                            : -(g * a / (w * w)) *
                                  (1 - std::exp(-z * w * t) * (std::cos(wd * t) + z * w / wd * std::sin(wd * t)));
    worst = std::max(worst, std::abs((s.sim_mm[0] - s.cmd_mm[0]) - e));
    EXPECT_DOUBLE_EQ(s.cmd_mm[0], t <= 0 ? 0.0 : a * t * t / 2);
    EXPECT_EQ(s.sim_mm[1], s.cmd_mm[1]);
  }
  EXPECT_LT(worst, 1e-12 * g * a / (w * w) * 10);
}

// A velocity step v from rest (x_b = v t): e'(0+) = -g v, so e(t) = -(g v / wd) exp(-z w t) sin(wd t);
// after the piece ends, the command rests (a velocity step -v).
TEST(ModalPlant, VelocityStepAndRestMatchClosedForm) {
  const double f = 40.0, z = 0.05, g = 1.0, v = 50.0, T = 0.0123;
  const AxisModel m = AxisModel::belt(f, z);
  const double w = 2 * kPi * f, wd = w * std::sqrt(1 - z * z);
  PieceSimulator sim(AxisModel::rigid(), m, 2000.0, 0.0);
  CommandPiece p;
  p.duration_s = T;
  p.c[1][0] = 1.0;
  p.c[1][1] = v;
  Collected c;
  auto sink = [&](const PlantSample& s) { c.s.push_back(s); };
  sim.push(p, sink);
  sim.rest_until(400, sink);
  ASSERT_EQ(c.s.size(), 401u);
  // Response to +v at 0 and -v at T (superposition of the two steps' free responses).
  auto step = [&](double t) { return t <= 0 ? 0.0 : -(g * v / wd) * std::exp(-z * w * t) * std::sin(wd * t); };
  double worst = 0.0;
  for (const PlantSample& s : c.s) {
    const double e = step(s.t_s) - step(s.t_s - T);
    worst = std::max(worst, std::abs((s.sim_mm[1] - s.cmd_mm[1]) - e));
  }
  EXPECT_LT(worst, 1e-13);
  EXPECT_DOUBLE_EQ(c.s.back().cmd_mm[1], 1.0 + v * T);
}

// Several polynomial pieces of degree up to 6 (velocity jumps between some of them), both
// axes, against the physical ODE integrated by Dormand-Prince between the breaks.
TEST(ModalPlant, PolynomialPiecesMatchIntegratedOde) {
  const double f0 = 31.0, z0 = 0.12, f1 = 57.0, z1 = 0.03;
  const double w0 = 2 * kPi * f0, w1 = 2 * kPi * f1;
  std::vector<CommandPiece> pieces;
  double t = 0.0;
  const double dur[] = {0.0137, 0.021, 0.0049, 0.033, 0.0081};
  for (int i = 0; i < 5; ++i) {
    CommandPiece p;
    p.t0_s = t;
    p.duration_s = dur[i];
    for (int a = 0; a < 2; ++a) {
      for (int k = 0; k <= 6 - i % 3; ++k) {
        p.c[static_cast<std::size_t>(a)][static_cast<std::size_t>(k)] =
            std::sin(1.7 * k + 0.9 * i + 2.3 * a) * std::pow(8.0, k) / (k + 1);
      }
    }
    if (i > 0) {  // continuous position (the velocity may jump)
      const CommandPiece& q = pieces.back();
      for (std::size_t a = 0; a < 2; ++a) {
        double x = 0.0;
        for (int k = kCommandPieceCoeffs - 1; k >= 0; --k) x = x * q.duration_s + q.c[a][static_cast<std::size_t>(k)];
        p.c[a][0] = x;
      }
    }
    pieces.push_back(p);
    t += dur[i];
  }
  const double rate = 1500.0;
  PieceSimulator sim(AxisModel::belt(f0, z0), AxisModel::belt(f1, z1), rate, -0.002);
  std::vector<PlantSample> out;
  auto sink = [&](const PlantSample& s) { out.push_back(s); };
  for (const auto& p : pieces) sim.push(p, sink);
  sim.rest_until(sim.next_k() + 60, sink);

  auto eval = [](const CommandPiece& p, int a, double tau, double& x, double& v) {
    x = v = 0.0;
    for (int k = kCommandPieceCoeffs - 1; k >= 0; --k) {
      x = x * tau + p.c[static_cast<std::size_t>(a)][static_cast<std::size_t>(k)];
      if (k >= 1) v = v * tau + k * p.c[static_cast<std::size_t>(a)][static_cast<std::size_t>(k)];
    }
  };
  // The command at rest after the last piece: its end position.
  double xe[2], ve[2];
  for (int a = 0; a < 2; ++a) eval(pieces.back(), a, pieces.back().duration_s, xe[a], ve[a]);
  // x_b, x_b' on the piece covering the open interval (lo, hi) (index pi, or rest if pi == 5).
  auto input = [&](std::size_t pi, double tt, double (&xb)[2], double (&vb)[2]) {
    for (int a = 0; a < 2; ++a) {
      if (pi >= pieces.size()) {
        xb[a] = xe[a];
        vb[a] = 0.0;
      } else {
        eval(pieces[pi], a, tt - pieces[pi].t0_s, xb[a], vb[a]);
      }
    }
  };
  // Reference at every sample time: the physical state starts at rest on the first piece's
  // start; integrate piece by piece (state continuous across the breaks).
  double worst = 0.0, scale = 0.0;
  for (const PlantSample& s : out) {
    if (s.t_s <= 0.0) continue;
    testing::State4 x{pieces[0].c[0][0], 0.0, pieces[0].c[1][0], 0.0};
    double tc = 0.0;
    for (std::size_t pi = 0; pi <= pieces.size() && tc < s.t_s; ++pi) {
      const double end = pi < pieces.size() ? std::min(s.t_s, pieces[pi].t0_s + pieces[pi].duration_s) : s.t_s;
      if (end <= tc) continue;
      auto fn = [&](double tt, const testing::State4& y) {
        double xb[2], vb[2];
        input(pi, tt, xb, vb);
        return testing::State4{y[1], -2 * z0 * w0 * (y[1] - vb[0]) - w0 * w0 * (y[0] - xb[0]), y[3],
                               -2 * z1 * w1 * (y[3] - vb[1]) - w1 * w1 * (y[2] - xb[1])};
      };
      x = testing::dopri5(fn, tc, end, x, 1e-12, 1e-13);
      tc = end;
    }
    worst = std::max({worst, std::abs(x[0] - s.sim_mm[0]), std::abs(x[2] - s.sim_mm[1])});
    scale = std::max({scale, std::abs(s.sim_mm[0] - s.cmd_mm[0]), std::abs(s.sim_mm[1] - s.cmd_mm[1])});
  }
  ASSERT_GT(scale, 1e-3);  // the command really excites the modes
  EXPECT_LT(worst, 1e-9 * std::max(1.0, scale));
}

// The free-vibration amplitude at rest equals the decaying envelope of the step response.
TEST(ModalPlant, VibrationAfterVelocityStepIsEnvelope) {
  const double f = 40.0, z = 0.0;
  const AxisModel m = AxisModel::belt(f, z);
  ModalPlant plant(m, AxisModel::rigid(), 1e-3);
  plant.velocity_jump(20.0, 0.0);  // |e'| = 20 mm/s => amplitude 20 / w
  InputTerms u{};
  for (int i = 0; i < 7; ++i) plant.step(0, u);
  EXPECT_NEAR(plant.vibration_mm(0, u)[0], 20.0 / (2 * kPi * f), 1e-13);
  EXPECT_EQ(plant.vibration_mm(0, u)[1], 0.0);
}

TEST(PieceSimulator, RejectsRateBelowNyquist) {
  EXPECT_THROW(PieceSimulator(AxisModel::belt(600.0, 0.1), AxisModel::rigid(), 1000.0, 0.0), Error);
}

}  // namespace
}  // namespace amctl::dynamics
