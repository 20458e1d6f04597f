// Exact discretisation against closed forms: e^{-aT} of a first-order system, the analytic
// step response of a mass-spring-damper, the double integrator, and an FOH ramp.
#include "amctl/control/discretize.hpp"

#include <cmath>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::control {
namespace {

TEST(DiscretizeZoh, FirstOrderSystemIsExpOfMinusATAndItsIntegral) {
  // x' = -a x + b u: Phi = e^{-aT}, Gamma = (b/a)(1 - e^{-aT}).
  const double a = 3.0, b = 2.0, period = 0.1;
  const auto sys = StateSpace::siso(Eigen::MatrixXd{{-a}}, Eigen::VectorXd{{b}},
                                    Eigen::RowVectorXd{{1.0}});
  const Discretization d = discretize_zoh(sys, period);
  EXPECT_EQ(d.period_s, period);
  EXPECT_NEAR(d.Phi(0, 0), std::exp(-a * period), 1e-15);
  EXPECT_NEAR(d.Gamma0(0, 0), b / a * (1.0 - std::exp(-a * period)), 1e-15);
  EXPECT_EQ(d.Gamma1.size(), 0);
  EXPECT_EQ(d.C, sys.C());
  EXPECT_EQ(d.D, sys.D());
}

TEST(DiscretizeZoh, DoubleIntegratorGetsHalfTSquared) {
  // x'' = u: Phi = [[1, T], [0, 1]], Gamma = [T^2/2, T] (A nilpotent: the series ends).
  const double period = 0.25;
  const StateSpace sys(Eigen::MatrixXd{{0.0, 1.0}, {0.0, 0.0}}, Eigen::MatrixXd{{0.0}, {1.0}},
                       Eigen::MatrixXd{{1.0, 0.0}}, Eigen::MatrixXd{{0.0}});
  const Discretization d = discretize_zoh(sys, period);
  EXPECT_NEAR(d.Phi(0, 0), 1.0, 1e-15);
  EXPECT_NEAR(d.Phi(0, 1), period, 1e-15);
  EXPECT_NEAR(d.Phi(1, 0), 0.0, 1e-15);
  EXPECT_NEAR(d.Gamma0(0, 0), period * period / 2.0, 1e-15);
  EXPECT_NEAR(d.Gamma0(1, 0), period, 1e-15);
}

TEST(DiscretizeZoh, MassSpringDamperSampledStepResponseIsTheAnalyticOne) {
  // m x'' + c x' + k x = F, F = 1 N from rest. With w = sqrt(k/m), z = c/(2 sqrt(k m)),
  // wd = w sqrt(1 - z^2): x(t) = (1/k) (1 - e^{-z w t} (cos wd t + z/sqrt(1 - z^2) sin wd t)).
  // A step is held exactly by the ZOH, so every sample must match to rounding.
  const double m = 0.5, k = 200.0, z = 0.1;
  const double w = std::sqrt(k / m), c = 2.0 * z * std::sqrt(k * m);
  const double wd = w * std::sqrt(1.0 - z * z);
  const StateSpace sys(Eigen::MatrixXd{{0.0, 1.0}, {-k / m, -c / m}},
                       Eigen::MatrixXd{{0.0}, {1.0 / m}}, Eigen::MatrixXd{{1.0, 0.0}},
                       Eigen::MatrixXd{{0.0}});
  const double period = 0.004;
  const Discretization d = discretize_zoh(sys, period);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(2);
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 1.0);
  double max_err = 0.0;
  const int steps = 500;  // 2 s: about six periods of the ringing
  for (int i = 1; i <= steps; ++i) {
    x = d.Phi * x + d.Gamma0 * u;
    const double t = i * period;
    const double exact =
        (1.0 - std::exp(-z * w * t) * (std::cos(wd * t) + z / std::sqrt(1.0 - z * z) *
                                                              std::sin(wd * t))) / k;
    max_err = std::max(max_err, std::abs((d.C * x)(0) - exact));
  }
  EXPECT_LT(max_err, 1e-12 / k);
  // The overshoot is the textbook e^{-pi z / sqrt(1 - z^2)} of the final value 1/k.
  const double t_peak = std::numbers::pi / wd;
  const double x_peak = (1.0 + std::exp(-std::numbers::pi * z / std::sqrt(1.0 - z * z))) / k;
  const double exact_peak =
      (1.0 - std::exp(-z * w * t_peak) * (std::cos(wd * t_peak) +
                                          z / std::sqrt(1.0 - z * z) * std::sin(wd * t_peak))) / k;
  EXPECT_NEAR(exact_peak, x_peak, 1e-15);
}

TEST(DiscretizeFoh, IsExactForInputsLinearInsideThePeriod) {
  // x' = -x + u, u(t) = t: x(T) from 0 = T - 1 + e^{-T}.
  const auto sys = StateSpace::siso(Eigen::MatrixXd{{-1.0}}, Eigen::VectorXd{{1.0}},
                                    Eigen::RowVectorXd{{1.0}});
  const double period = 0.3;
  const Discretization d = discretize_foh(sys, period);
  const double x1 = d.Phi(0, 0) * 0.0 + d.Gamma0(0, 0) * 0.0 + d.Gamma1(0, 0) * (period - 0.0);
  EXPECT_NEAR(x1, period - 1.0 + std::exp(-period), 1e-15);
  // ZOH of the same input (u held at u_k = 0) gives 0 and its Gamma0 is 1 - e^{-T}.
  EXPECT_NEAR(discretize_zoh(sys, period).Gamma0(0, 0), 1.0 - std::exp(-period), 1e-15);
}

TEST(DiscretizePolynomial, OneTermIsTheZohAndBadInputIsRejected) {
  const Eigen::MatrixXd A{{0.0, 1.0}, {-4.0, -0.4}}, B{{0.0}, {1.0}};
  const StateSpace sys(A, B, Eigen::MatrixXd{{1.0, 0.0}}, Eigen::MatrixXd{{0.0}});
  const PolynomialDiscretization p = discretize_polynomial(A, B, 1, 0.05);
  const Discretization d = discretize_zoh(sys, 0.05);
  EXPECT_EQ(p.Phi, d.Phi);
  EXPECT_EQ(p.Psi, d.Gamma0);
  EXPECT_THROW((void)discretize_zoh(sys, 0.0), Error);
  EXPECT_THROW((void)discretize_zoh(sys, -0.1), Error);
  EXPECT_THROW((void)discretize_zoh(sys, std::nan("")), Error);
  EXPECT_THROW((void)discretize_polynomial(A, B, 0, 0.05), Error);
  EXPECT_THROW((void)discretize_polynomial(A, Eigen::MatrixXd::Ones(3, 1), 1, 0.05), Error);
  EXPECT_THROW((void)discretize_polynomial(Eigen::MatrixXd::Ones(2, 3), B, 1, 0.05), Error);
}

}  // namespace
}  // namespace amctl::control
