#include "amctl/dynamics/model.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/control/discretize.hpp"

namespace amctl::dynamics {
namespace {

void expect_error_naming(const std::function<void()>& f, const std::string& name) {
  try {
    f();
    FAIL() << "expected amctl::Error naming " << name;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(AxisModel, BeltFromMassStiffnessAndDampingGivesFrequencyAndRatio) {
  // k/m = 5000/0.5 = 1e4 -> w = 100 rad/s; c/(2 sqrt(k m)) = 50/(2*50) = 0.5
  const AxisModel m = AxisModel::belt(BeltParameters{0.5, 5000.0, 50.0});
  ASSERT_EQ(m.modes().size(), 1u);
  EXPECT_NEAR(m.modes()[0].natural_frequency_hz * 2 * std::numbers::pi, 100.0, 1e-12);
  EXPECT_NEAR(m.modes()[0].damping_ratio, 0.5, 1e-15);
}

TEST(AxisModel, ScaledModalMatricesHaveTheBeltPolynomial) {
  const AxisModel m = AxisModel::belt_rad_s(100.0, 0.5);
  const Eigen::MatrixXd A = m.A();
  // characteristic polynomial s^2 + 2 z w s + w^2: trace -100, det 1e4
  EXPECT_NEAR(A.trace(), -100.0, 1e-12);
  EXPECT_NEAR(A.determinant(), 1e4, 1e-8);
  // static gain from commanded acceleration to error: -1/w^2 = -C A^{-1} B ... sign: e = -a/w^2
  const double g = -(m.C() * A.inverse() * m.B())(0, 0);
  EXPECT_NEAR(g, -1e-4, 1e-16);
}

TEST(AxisModel, RejectsNonPhysicalParametersNamingThem) {
  expect_error_naming([] { (void)AxisModel::belt(BeltParameters{-1.0, 5000.0, 1.0}); }, "mass_kg");
  expect_error_naming([] { (void)AxisModel::belt(BeltParameters{1.0, 0.0, 1.0}); }, "stiffness");
  expect_error_naming([] { (void)AxisModel::belt(40.0, -0.1); }, "damping_ratio");
  expect_error_naming([] { (void)AxisModel::belt(0.0, 0.1); }, "natural_frequency_hz");
  expect_error_naming([] { (void)AxisModel::from_modes({Mode{30, 0.1, 1}, Mode{-2, 0.1, 1}}); },
                      "mode 1: natural_frequency_hz");
}

TEST(AxisModel, SampleRateAtOrBelowNyquistIsRejected) {
  const AxisModel m = AxisModel::from_modes({Mode{40.0, 0.1, 0.7}, Mode{120.0, 0.05, 0.3}});
  EXPECT_NO_THROW(require_above_nyquist(241.0, {&m}));
  expect_error_naming([&] { require_above_nyquist(240.0, {&m}); }, "sample_rate_hz");
  expect_error_naming([&] { require_above_nyquist(0.0, {&m}); }, "sample_rate_hz");
}

TEST(StateSpace, Seed312UsesEachAxisOwnParameters) {
  const control::StateSpace s = seed000_xy_state_space(100.0, 0.5, 200.0, 0.1);
  EXPECT_DOUBLE_EQ(s.A()(1, 0), -1e4);
  EXPECT_DOUBLE_EQ(s.A()(3, 2), -4e4);  // the printed 3.12 repeats k_x/m_x here
  EXPECT_DOUBLE_EQ(s.A()(3, 3), -40.0);
  EXPECT_DOUBLE_EQ(s.B()(3, 2), 4e4);
  EXPECT_DOUBLE_EQ(s.B()(3, 3), 40.0);
}

TEST(Discretize, ZohOfSeedModelMatchesScipy) {
  // tests/reference/dynamics_reference.py (scipy.signal.cont2discrete, method="zoh").
  const control::StateSpace s = seed000_axis_state_space(100.0, 0.5);
  const control::Discretization d = control::discretize_zoh(s, 0.005);
  const double phi[4] = {8.9559452654492056e-01, 3.7734520347490683e-03,
                         -3.7734520347490687e+01, 5.1824932307001370e-01};
  const double gam[4] = {1.0440547345507939e-01, 1.0440547345507939e-03,
                         3.7734520347490687e+01, 3.7734520347490685e-01};
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(d.Phi(i / 2, i % 2), phi[i], 1e-12 * (1 + std::abs(phi[i])));
    EXPECT_NEAR(d.Gamma0(i / 2, i % 2), gam[i], 1e-12 * (1 + std::abs(gam[i])));
  }
}

}  // namespace
}  // namespace amctl::dynamics
