// Reference values: tests/reference/thermal_powder_bed_tf.py (numpy/scipy, printed numbers
// hard-coded below) and closed forms derived in docs/thermal.md.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

#include "amctl/core/error.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"

using namespace amctl::thermal;
using cd = std::complex<double>;

namespace {
const PowderMaterial kPa12{};
constexpr double kL = 1e-4;  // one layer, l0 = 0.1 mm

void expect_close(cd got, cd want, double rel) {
  EXPECT_NEAR(got.real(), want.real(), rel * std::abs(want)) << got << " vs " << want;
  EXPECT_NEAR(got.imag(), want.imag(), rel * std::abs(want)) << got << " vs " << want;
}
}  // namespace

TEST(PowderBedTf, ExactTransferFunctionMatchesScipyAtSamplePoints) {
  const PowderBedTf g(kPa12, kL);
  expect_close(g.eval({1.0, 0.0}), {5.253867608089e-03, 0.0}, 1e-11);
  expect_close(g.eval({0.0, 10.0}), {1.186838175390e-04, -5.190310326984e-04}, 1e-11);
  expect_close(g.eval({-50.0, 30.0}), {7.433526888698e-05, -7.974049932685e-05}, 1e-11);
  expect_close(g.eval({0.0, 1e3}), {3.028315089982e-05, -3.028251233996e-05}, 1e-11);
  expect_close(g.eval({5e3, 2e3}), {1.812172277664e-05, -3.489924929105e-06}, 1e-11);
}

TEST(PowderBedTf, LargeFrequencyEvaluationIsFiniteAndTendsToTheSemiInfiniteSolid) {
  // For |s| -> inf with Re sqrt(s) > 0, coth -> 1 and G -> a/(k0 sqrt(s)) = 1/(e sqrt(s)), e the
  // thermal effusivity sqrt(k0 rho Cp). The naive cosh/sinh quotient overflows here.
  const PowderBedTf g(kPa12, kL);
  const double e = std::sqrt(kPa12.conductivity_w_mk * kPa12.volumetric_heat_j_m3k());
  for (double w : {1e8, 1e12, 1e16, 1e20}) {
    const cd s(0.0, w);
    const cd got = g.eval(s);
    ASSERT_TRUE(std::isfinite(got.real()) && std::isfinite(got.imag()));
    expect_close(got, 1.0 / (e * std::sqrt(s)), 1e-12);
  }
}

TEST(PowderBedTf, PolesAndZerosAreTheRootsOfSinhAndCosh) {
  const PowderBedTf g(kPa12, kL);
  EXPECT_NEAR(g.pole(1), -1.419153502478e+02, 1e-9);
  EXPECT_DOUBLE_EQ(g.pole(3), 9.0 * g.pole(1));
  EXPECT_DOUBLE_EQ(g.zero(0), g.pole(1) / 4.0);
  for (int k = 0; k < 5; ++k) EXPECT_LT(std::abs(g.eval({g.zero(k), 0.0})), 1e-15);
  for (int k = 1; k < 5; ++k) EXPECT_GT(std::abs(g.eval({g.pole(k) * (1 + 1e-9), 0.0})), 1e3);
}

TEST(PowderBedTf, ResiduesMatchContourIntegralsNotThePrintedEquationTen) {
  const PowderBedTf g(kPa12, kL);
  EXPECT_NEAR(g.residue(0), 5.135368308615e-03, 1e-14);
  EXPECT_NEAR(g.residue(1), 1.027073661723e-02, 1e-14);
  EXPECT_NEAR(g.residue(3), 1.027073661723e-02, 1e-14);
  // The paper's (10) would give 2 l/k0 / l^2 = 2/(k0 l) for the mode residue (per unit s).
  EXPECT_GT(2.0 / (kPa12.conductivity_w_mk * kL) / g.residue(1), 1e6);
  // Numerical limit (s - p) G(s) as s -> p.
  for (int k = 0; k <= 4; ++k) {
    const double p = g.pole(k);
    const double h = 1e-7 * std::max(1.0, std::abs(p));
    const cd lim = cd(h, 0.0) * g.eval({p + h, 0.0});
    EXPECT_NEAR(lim.real(), g.residue(k), 1e-6 * g.residue(k)) << "k=" << k;
  }
}

TEST(PowderBedTf, ModalExpansionConvergesToTheExactFunctionAtManyPoints) {
  const PowderBedTf g(kPa12, 7 * kL);
  const int n = 4000;
  // G - G_N has modulus <= tail bound (sum over k>N of r/|p_k|) on the closed right half plane
  // and at any point away from the poles the remainder is at most sum r/|s - p_k|.
  for (double re : {0.0, 0.3, 5.0}) {
    for (double im : {0.0, 0.01, 1.0, 30.0, 1e3}) {
      const cd s(re, im);
      if (s == cd(0.0, 0.0)) continue;
      const cd diff = g.eval(s) - g.eval_modal(s, n);
      EXPECT_LE(std::abs(diff), g.modal_tail_bound(n) * (1 + 1e-9)) << s;
      // For |s| << |p_N| the remainder sum_{k>N} r/(s - p_k) is the DC tail up to O(|s|/|p_N|):
      // a wrong residue or a missing constant would show here at full size.
      EXPECT_NEAR(diff.real(), g.modal_tail_bound(n), 1e-3 * g.modal_tail_bound(n)) << s;
      EXPECT_NEAR(diff.imag(), 0.0, 1e-3 * g.modal_tail_bound(n)) << s;
    }
  }
  // On the negative real axis between poles too (s = -1, between 0 and p_1 for 7 layers).
  const cd s(-1.0, 0.0);
  EXPECT_NEAR(std::abs(g.eval(s) - g.eval_modal(s, n)), 0.0, 1e-3 * std::abs(g.eval(s)));
}

TEST(PowderBedTf, RegularPartEqualsLOver3K0AtZeroAndIsContinuous) {
  const PowderBedTf g(kPa12, kL);
  EXPECT_NEAR(g.eval_regular({0.0, 0.0}).real(), kL / (3 * 0.28), 1e-18);
  for (double w : {1e-9, 1e-3, 1.0, 100.0}) {
    const cd s(0.0, w);
    const cd direct = g.eval(s) - g.residue(0) / s;
    EXPECT_NEAR(std::abs(g.eval_regular(s) - direct), 0.0,
                1e-13 * std::abs(g.eval(s)) + 1e-20);
  }
}

TEST(PowderBedTf, TailBoundIsTheBaselTailAndEqualsTheErrorAtDc) {
  EXPECT_NEAR(basel_tail(0), std::numbers::pi * std::numbers::pi / 6, 1e-15);
  EXPECT_NEAR(basel_tail(1), std::numbers::pi * std::numbers::pi / 6 - 1, 1e-15);
  EXPECT_NEAR(basel_tail(1000), 9.995001666666667e-04, 1e-16);  // 1/N - 1/(2N^2) + 1/(6N^3)
  const PowderBedTf g(kPa12, kL);
  // delta_1 = 2 l/(k0 pi^2)(pi^2/6 - 1), independent of the diffusivity.
  EXPECT_NEAR(g.modal_tail_bound(1), 4.667534501737778e-05, 1e-17);
  const cd dc = g.eval_regular({0.0, 0.0}) - g.residue(1) / (-g.pole(1));
  EXPECT_NEAR(dc.real(), g.modal_tail_bound(1), 1e-16);
  // The printed (13) carries an extra 1/a^2: 324.6 instead of 4.67e-5.
  EXPECT_NEAR(g.printed_bound_13(1), 324.6070208765692, 1e-9);
}

TEST(PowderBedTf, BodeDataOfTheIntegratorAtLowFrequency) {
  const PowderBedTf g(kPa12, kL);
  const auto b = g.bode(1e-4, 1e-2, 3);
  ASSERT_EQ(b.size(), 3u);
  EXPECT_NEAR(b[0].magnitude, g.residue(0) / 1e-4, 1e-6 * g.residue(0) / 1e-4);
  EXPECT_NEAR(b[0].phase_deg, -90.0, 1e-3);
  const auto high = g.bode(1e6, 1e8, 3, -1);
  EXPECT_NEAR(high.back().phase_deg, -45.0, 1e-6);  // semi-infinite solid: 1/sqrt(j w)
  const auto modal = g.bode(1e6, 1e8, 3, 1);
  EXPECT_NEAR(modal.back().phase_deg, -90.0, 1e-3);  // rational G_1 rolls off as 1/s
}

TEST(PowderBedTf, RejectsNonPositiveConstantsNamingThem) {
  PowderMaterial m;
  m.conductivity_w_mk = 0.0;
  try {
    PowderBedTf g(m, kL);
    FAIL();
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("k0"), std::string::npos);
  }
  EXPECT_THROW(PowderBedTf(kPa12, -1e-4), amctl::Error);
  m = PowderMaterial{};
  m.density_kg_m3 = -5;
  EXPECT_THROW(PowderBedTf(m, kL), amctl::Error);
}
