// Direct collocation (docs/compensation.md, section 2d): the Hermite-Simpson step against an
// independent integration of the physical belt ODE, and the seed base case with and without
// the base acceleration bound, against hand-computed limits.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "../../src/compensation/detail.hpp"
#include "amctl/compensation/compensate.hpp"
#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/stream.hpp"
#include "seed_case.hpp"

namespace amctl::compensation {
namespace {

using seed_case::plan_text;
using seed_case::seed_plan;

CompensationOptions seed_collocation() {
  CompensationOptions o;
  o.method = Method::collocation;
  o.model_x = o.model_y = o.plant_x = o.plant_y = dynamics::AxisModel::belt_rad_s(100.0, 0.5);
  return o;
}

// One step of the physical model m x'' + c (x' - x_b') + k (x - x_b) = 0 (w = 100 rad/s,
// z = 0.5) under x_b'' linear in time, by classic RK4 with 1e-7 s steps: state (x_b, v_b, x, x').
std::array<double, 4> physical_step(std::array<double, 4> s, double u0, double u1, double h) {
  const double w = 100.0, z = 0.5;
  const auto f = [&](double t, const std::array<double, 4>& q) {
    const double u = u0 + (u1 - u0) * t / h;
    return std::array<double, 4>{q[1], u, q[3], -2.0 * z * w * (q[3] - q[1]) - w * w * (q[2] - q[0])};
  };
  const int n = static_cast<int>(std::lround(h / 1e-7));
  const double dt = h / n;
  for (int i = 0; i < n; ++i) {
    const double t = i * dt;
    const auto k1 = f(t, s);
    std::array<double, 4> q{};
    for (int j = 0; j < 4; ++j) q[j] = s[j] + 0.5 * dt * k1[j];
    const auto k2 = f(t + 0.5 * dt, q);
    for (int j = 0; j < 4; ++j) q[j] = s[j] + 0.5 * dt * k2[j];
    const auto k3 = f(t + 0.5 * dt, q);
    for (int j = 0; j < 4; ++j) q[j] = s[j] + dt * k3[j];
    const auto k4 = f(t + dt, q);
    for (int j = 0; j < 4; ++j) s[j] += dt / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
  }
  return s;
}

// The Hermite-Simpson defect solved for the next node: its nozzle position against RK4 of the
// physical ODE. The local error of Hermite-Simpson is O(h^5): halving h divides it by ~32.
double hs_step_error(double h) {
  const double w = 100.0, w_ref = 100.0;
  const detail::CollocationAxis ax(dynamics::AxisModel::belt_rad_s(w, 0.5), w_ref, h);
  const double xb = 1.0, vb = 20.0, e = 0.01, ed = 0.5, u0 = 3000.0, u1 = -2000.0;
  // Scaled state: [x_b, v_b / w_r, e, e' / w] (the model's modal scaling), u / w_r^2.
  Eigen::VectorXd S0(4);
  S0 << xb, vb / w_ref, e, ed / w;
  const double s0 = u0 / (w_ref * w_ref), s1 = u1 / (w_ref * w_ref);
  const Eigen::VectorXd S1 = -ax.Q().lu().solve(ax.P() * S0 + ax.e1() * s0 + ax.e2() * s1);
  const auto ref = physical_step({xb, vb, xb + e, vb + ed}, u0, u1, h);
  EXPECT_NEAR(S1(0), ref[0], 1e-12 + 1e-6 * h) << "the command's double integrator is exact for linear u";
  return std::abs(ax.output_row() * S1 - ref[2]);
}

TEST(Collocation, HermiteSimpsonStepIsFifthOrderAgainstTheODE) {
  const double e4 = hs_step_error(4e-3), e2 = hs_step_error(2e-3), e1 = hs_step_error(1e-3);
  EXPECT_LT(e1, 1e-7);  // mm, one 1 ms step
  EXPECT_GT(e4 / e2, 24.0);
  EXPECT_LT(e4 / e2, 40.0);
  EXPECT_GT(e2 / e1, 24.0);
  EXPECT_LT(e2 / e1, 40.0);
}

TEST(Collocation, SeedBaseCaseWithoutBoundTracksBelowOneMicron) {
  const CompensationResult r = compensate(seed_plan(), seed_collocation());
  EXPECT_EQ(r.status, compensation::CompensationStatus::ok);
  EXPECT_EQ(r.solver_status, "Solve_Succeeded");
  EXPECT_NEAR(r.uncompensated_max_tracking_error_mm, 0.469, 0.001);
  EXPECT_LT(r.max_tracking_error_mm, 1e-3);
  EXPECT_LT(r.max_defect_mm, 1e-9);
  // At rest at the start and end positions.
  EXPECT_NEAR(r.x_cmd_mm.front(), 0.0, 1e-9);
  EXPECT_NEAR(r.y_cmd_mm.front(), 0.0, 1e-9);
  EXPECT_NEAR(r.x_cmd_mm.back(), 10.0, 1e-9);
  EXPECT_NEAR(r.y_cmd_mm.back(), 10.0, 1e-9);
  EXPECT_NEAR(r.x_cmd_mm[r.x_cmd_mm.size() - 2], 10.0, 1e-6);
}

TEST(Collocation, SeedBaseCaseRespectsTheBaseAccelerationBound) {
  CompensationOptions o = seed_collocation();
  o.max_base_accel_mm_s2 = 10000.0;
  const CompensationResult r = compensate(seed_plan(), o);
  ASSERT_EQ(r.status, compensation::CompensationStatus::ok) << r.message;
  EXPECT_LE(r.max_tracking_error_mm, 5e-3);  // issue 10: <= 5 um with the 10 000 mm/s^2 bound
  EXPECT_LE(r.peak_command_accel_mm_s2, 10000.0 * (1 + 1e-6));
  EXPECT_GT(r.peak_command_accel_mm_s2, 9990.0);  // the bound is active (unbounded: ~7e4)
  // The sampled command's second differences are averages of x_b'' over two steps, so they
  // respect the bound too: checked on the samples, independently of the solver's controls.
  const double h = 1.0 / r.sample_rate_hz;
  for (std::size_t k = 1; k + 1 < r.t_s.size(); ++k) {
    const double ax = (r.x_cmd_mm[k + 1] - 2 * r.x_cmd_mm[k] + r.x_cmd_mm[k - 1]) / (h * h);
    const double ay = (r.y_cmd_mm[k + 1] - 2 * r.y_cmd_mm[k] + r.y_cmd_mm[k - 1]) / (h * h);
    ASSERT_LE(std::hypot(ax, ay), 10000.0 * (1 + 1e-5)) << "sample " << k;
  }
}

TEST(Collocation, WithoutLeadInTheBoundCostsTwoOrdersOfMagnitude) {
  // Issue 10: with the bound and no lead-in, no command gets below ~92 um (an independent
  // least-squares optimum); the lead-in takes it to microns.
  CompensationOptions o = seed_collocation();
  o.max_base_accel_mm_s2 = 10000.0;
  o.lead_in_s = 0.0;
  const CompensationResult r = compensate(seed_plan(), o);
  ASSERT_EQ(r.status, compensation::CompensationStatus::ok) << r.message;
  EXPECT_GT(r.max_tracking_error_mm, 0.09);
  EXPECT_LT(r.max_tracking_error_mm, 0.2);
}

TEST(Collocation, ABoundThatCannotMoveRestToRestIsInfeasible) {
  // 14.142 mm from rest to rest in 0.42 s (0.08 s lead-in, 0.24 s motion, 0.1 s tail) needs
  // 4 d / T^2 = 320.68 mm/s^2 at least (bang-bang).
  CompensationOptions o = seed_collocation();
  o.max_base_accel_mm_s2 = 300.0;
  const CompensationResult r = compensate(seed_plan(), o);
  EXPECT_EQ(r.status, compensation::CompensationStatus::infeasible);
  EXPECT_NE(r.message.find("320.68"), std::string::npos) << r.message;
  EXPECT_TRUE(r.t_s.empty());
}

TEST(Collocation, WindowsAgreeWithOneSolveOverTheWholePath) {
  // A zigzag of ~1.6 s: three windows of 0.6 s (0.25 s preview) against one window.
  const auto moves = plan_text("G90\nG1 X0 Y0 F6000\nG1 X20 Y0\nG1 X20 Y15\nG1 X5 Y25\nG1 X40 Y25\nG1 X40 Y0\nG1 X25 Y10\n");
  CompensationOptions whole = seed_collocation();
  whole.max_base_accel_mm_s2 = 10000.0;
  whole.window_s = 10.0;
  CompensationOptions win = whole;
  win.window_s = 0.6;
  win.overlap_s = 0.25;
  const CompensationResult a = compensate(moves, whole), b = compensate(moves, win);
  ASSERT_EQ(a.status, compensation::CompensationStatus::ok) << a.message;
  ASSERT_EQ(b.status, compensation::CompensationStatus::ok) << b.message;
  EXPECT_EQ(a.windows, 1u);
  EXPECT_GE(b.windows, 3u);
  ASSERT_EQ(a.t_s.size(), b.t_s.size());
  double diff = 0.0;
  for (std::size_t k = 0; k < a.t_s.size(); ++k)
    diff = std::max(diff, std::hypot(a.x_cmd_mm[k] - b.x_cmd_mm[k], a.y_cmd_mm[k] - b.y_cmd_mm[k]));
  EXPECT_LT(diff, 1e-3) << "windowed command differs from the whole solve by " << diff << " mm";
  EXPECT_LT(b.max_tracking_error_mm, 1.5 * a.max_tracking_error_mm + 1e-4);
  EXPECT_LE(b.peak_command_accel_mm_s2, 10000.0 * (1 + 1e-6));
}

TEST(Collocation, BadOptionsAreRefusedByName) {
  CompensationOptions o = seed_collocation();
  o.effort_weight_s2 = -1.0;
  EXPECT_THROW(
      {
        try {
          compensate(seed_plan(), o);
        } catch (const Error& e) {
          EXPECT_NE(std::string(e.what()).find("--effort-weight-s2"), std::string::npos);
          throw;
        }
      },
      Error);
  o = seed_collocation();
  o.max_base_accel_mm_s2 = -5.0;
  EXPECT_THROW(compensate(seed_plan(), o), Error);
  o = seed_collocation();
  o.window_s = 0.01;  // shorter than the 0.08 s settling
  EXPECT_THROW(compensate(seed_plan(), o), Error);
}

TEST(MaxBaseAccel, OtherMethodsReportWhenTheirCommandBreaksTheBound) {
  CompensationOptions o = seed_collocation();
  o.method = Method::fbf;
  o.max_base_accel_mm_s2 = 1000.0;  // FBF's command peaks near 8 000 mm/s^2
  const CompensationResult r = compensate(seed_plan(), o);
  EXPECT_EQ(r.status, compensation::CompensationStatus::base_accel_limit_exceeded);
  EXPECT_NE(r.message.find("collocation"), std::string::npos);
  o.max_base_accel_mm_s2 = 1e6;
  EXPECT_EQ(compensate(seed_plan(), o).status, compensation::CompensationStatus::ok);
}

}  // namespace
}  // namespace amctl::compensation

namespace amctl::compensation {
namespace {

// The dense G-code read back independently: every G1's duration (length / F) and every G4 add
// up to the command's span, X/Y follow the command, Z and E follow the plan (relative E,
// retraction included).
TEST(DenseGcode, ReadBackGivesTheCommandThePlansExtrusionAndTheSpan) {
  const auto moves = plan_text(
      "G90\nM83\nG1 X0 Y0 Z0.2 F6000\nG1 X20 Y0 E1.0\nG1 E-0.8 F2400\nG1 X20 Y15 Z0.4 F6000\n"
      "G1 E0.8 F2400\nG1 X5 Y15 E0.75 F6000\n");
  CompensationOptions o = seed_collocation();
  o.method = Method::fbf;
  o.sample_z_e = true;
  const CompensationResult r = compensate(moves, o);
  ASSERT_EQ(r.status, compensation::CompensationStatus::ok);
  const std::string path = ::testing::TempDir() + "/dense.gcode";
  write_gcode(r, path);
  std::ifstream f(path);
  std::string line;
  double x = 0, y = 0, z = 0, e = 0, t = 0, max_dev = 0;
  const double h = 1.0 / r.sample_rate_hz;
  std::size_t k = 0;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == ';') continue;
    std::istringstream in(line);
    std::string cmd;
    in >> cmd;
    std::map<char, double> w;
    for (std::string word; in >> word;) w[word[0]] = std::stod(word.substr(1));
    if (cmd == "G4") {
      t += w['P'] / 1000.0;
      k += static_cast<std::size_t>(std::lround(w['P'] / 1000.0 / h));
    } else if (cmd == "G0" || cmd == "G1") {
      const double nx = w.count('X') ? w['X'] : x, ny = w.count('Y') ? w['Y'] : y, nz = w.count('Z') ? w['Z'] : z;
      const double d = std::sqrt((nx - x) * (nx - x) + (ny - y) * (ny - y) + (nz - z) * (nz - z));
      const double de = w.count('E') ? w['E'] : 0.0;
      if (cmd == "G1") {
        t += (d > 0 ? d : std::abs(de)) / (w['F'] / 60.0);
        ++k;
        ASSERT_LT(k, r.t_s.size());
        max_dev = std::max(max_dev, std::hypot(nx - r.x_cmd_mm[k], ny - r.y_cmd_mm[k]));
        EXPECT_NEAR(nz, r.z_des_mm[k], 1e-4);
      }
      x = nx, y = ny, z = nz, e += de;
    }
  }
  EXPECT_LE(max_dev, 0.5e-4 * std::sqrt(2.0) + 1e-12);  // X and Y printed at 0.1 um each
  EXPECT_NEAR(t, r.t_s.back() - r.t_s.front(), 1e-3 * (r.t_s.back() - r.t_s.front()));
  EXPECT_NEAR(e, 1.0 - 0.8 + 0.8 + 0.75, 1e-4);
  EXPECT_NEAR(x, 5.0, 1e-4);
  EXPECT_NEAR(y, 15.0, 1e-4);
  EXPECT_NEAR(z, 0.4, 1e-4);
}

TEST(DenseGcode, AnUnboundedCommandIsRefusedAndNothingIsWritten) {
  CompensationOptions o = seed_collocation();
  o.method = Method::invert;  // the trapezoid's inverse: unbounded command acceleration
  o.sample_z_e = true;
  const CompensationResult r = compensate(seed_plan(), o);
  const std::string path = ::testing::TempDir() + "/unbounded.gcode";
  std::remove(path.c_str());
  EXPECT_THROW(write_gcode(r, path), Error);
  EXPECT_FALSE(std::ifstream(path).good());
}

}  // namespace
}  // namespace amctl::compensation
