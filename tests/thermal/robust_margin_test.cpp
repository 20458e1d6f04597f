// Reference values: tests/reference/thermal_powder_bed_tf.py (numpy grid + scipy bounded
// maximisation; numpy.roots of the G_1 loop's characteristic polynomial).
#include <gtest/gtest.h>

#include <cmath>

#include "amctl/core/error.hpp"
#include "amctl/thermal/robust_margin.hpp"

using namespace amctl::thermal;

namespace {
const PowderMaterial kPa12{};
const PiController kPaperPi{0.3, 0.5};
}  // namespace

TEST(RobustMargin, PaperPiOnOneLayerMatchesScipyBothWays) {
  const PowderBedTf g(kPa12, 1e-4);
  const auto r = compute_margins(g, kPaperPi, 1);
  EXPECT_NEAR(r.margin_on_gn_sweep, 2.6390409866e-03, 1e-12);
  EXPECT_NEAR(r.margin_on_gn_hamiltonian, 2.6390409866e-03, 1e-11);
  EXPECT_NEAR(r.margin_on_g_sweep, 2.6856984441e-03, 1e-12);
  EXPECT_NEAR(r.margin_on_g_hamiltonian, 2.6856984441e-03, 1e-10);
  EXPECT_NEAR(r.peak_omega_gn, 5.550816e-02, 1e-6);
  EXPECT_NEAR(r.max_pole_real_gn, -7.920002073690e-04, 1e-12);
  EXPECT_TRUE(r.stable_gn);
  EXPECT_TRUE(r.stable_gm);
  // Neither the paper's 3.3 nor 0.78 holds in consistent SI units.
  EXPECT_LT(r.margin_on_gn_sweep, 0.01);
  EXPECT_LT(r.margin_on_g_sweep, 0.01);
}

TEST(RobustMargin, DeeperBedsMatchScipy) {
  const auto r5 = compute_margins(PowderBedTf(kPa12, 5e-4), kPaperPi, 1);
  EXPECT_NEAR(r5.margin_on_gn_sweep, 8.7534350043e-04, 1e-12);
  EXPECT_NEAR(r5.margin_on_g_sweep, 1.1087037532e-03, 1e-12);
  EXPECT_NEAR(r5.margin_on_g_hamiltonian, 1.1087037532e-03, 1e-9);
  const auto r10 = compute_margins(PowderBedTf(kPa12, 1e-3), kPaperPi, 1);
  EXPECT_NEAR(r10.margin_on_gn_sweep, 9.8042123756e-04, 1e-12);
  EXPECT_NEAR(r10.margin_on_g_sweep, 1.4471612674e-03, 1e-12);
}

TEST(RobustMargin, TheoremTwoLowerBoundHoldsForSeveralTruncations) {
  const PowderBedTf g(kPa12, 3e-3);
  for (int n : {1, 2, 5, 20}) {
    const auto r = compute_margins(g, kPaperPi, n, -0.01, 24);
    EXPECT_NEAR(r.hinf_g_minus_gn, r.bound_tail, 1e-9 * r.bound_tail) << n;
    EXPECT_TRUE(r.theorem2_holds) << n;
    EXPECT_GE(r.margin_on_g_sweep, r.theorem2_lower_bound) << n;
  }
}

TEST(RobustMargin, MarginCannotExceedOneOverKp) {
  // |C S| -> kp as w -> inf because G -> 0, so 1/kp is a ceiling for every plant and l.
  const PiController pi{0.3, 2.0};
  const PowderBedTf g(kPa12, 1e-6);
  const auto r = compute_margins(g, pi, 1);
  EXPECT_LE(r.margin_on_gn_sweep, 1.0 / 0.3 + 1e-12);
  EXPECT_LE(r.margin_on_g_sweep, 1.0 / 0.3 + 1e-12);
}

TEST(RobustMargin, HamiltonianNormOfAFirstOrderLagIsItsDcGain) {
  StateSpace s;
  s.a = Eigen::MatrixXd::Constant(1, 1, -2.0);
  s.b = Eigen::VectorXd::Constant(1, 1.0);
  s.c = Eigen::RowVectorXd::Constant(1, 3.0);
  s.d = 0.0;
  EXPECT_NEAR(hinf_norm_hamiltonian(s), 1.5, 1e-8);
  // A lightly damped resonance 1/(s^2 + 2 z s + 1): peak 1/(2 z sqrt(1 - z^2)).
  StateSpace r;
  const double z = 0.05;
  r.a = Eigen::MatrixXd(2, 2);
  r.a << 0, 1, -1, -2 * z;
  r.b = Eigen::VectorXd(2);
  r.b << 0, 1;
  r.c = Eigen::RowVectorXd(2);
  r.c << 1, 0;
  EXPECT_NEAR(hinf_norm_hamiltonian(r), 1.0 / (2 * z * std::sqrt(1 - z * z)), 1e-7);
}

TEST(RobustMargin, HankelBestMarginIsResidueOverTwoBeta) {
  const PowderBedTf g(kPa12, 1e-4);
  EXPECT_NEAR(hankel_best_margin(g, -0.01), 5.135368308615e-03 / 0.02, 1e-12);
  EXPECT_THROW((void)hankel_best_margin(g, 0.0), amctl::Error);
}

TEST(RobustMargin, RejectsUnrealisablePi) {
  const PowderBedTf g(kPa12, 1e-4);
  EXPECT_THROW((void)compute_margins(g, PiController{0.3, 0.0}, 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, PiController{-1.0, 0.5}, 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, kPaperPi, 0), amctl::Error);
  try {
    (void)compute_margins(g, PiController{0.3, -1.0}, 1);
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("Ti"), std::string::npos);
  }
}
