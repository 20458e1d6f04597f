// Reference values: tests/reference/thermal_powder_bed_tf.py (numpy grid + scipy bounded
// maximisation; numpy.roots of the G_1 loop's characteristic polynomial).
#include <gtest/gtest.h>

#include <cmath>

#include "amctl/control/pid.hpp"
#include "amctl/control/state_space.hpp"
#include "amctl/core/error.hpp"
#include "amctl/thermal/robust_margin.hpp"
#include "amctl/thermal/studies.hpp"

using namespace amctl::thermal;
using amctl::control::PidGains;

namespace {
const PowderMaterial kPa12{};
const PidGains kPaperPi = PidGains::standard(0.3, 0.5);

// Under AddressSanitizer (the asan preset defines AMCTL_SANITIZE) the slowest tests took
// minutes: there they run a smaller problem with the same assertions. Fewer modes in the
// Hamiltonian realisation of G (the assertions that use it are bounds or counts), and a
// shallower bed with fewer modes for the two-ways agreement.
#ifdef AMCTL_SANITIZE
constexpr int kHamiltonianModes = 20;
constexpr double kDeepBedM = 3e-3;  // 30 layers
constexpr int kDeepBedModes = 24;
#else
constexpr int kHamiltonianModes = 60;
constexpr double kDeepBedM = 10e-3;  // 100 layers
constexpr int kDeepBedModes = 60;
#endif
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

TEST(RobustMargin, TheoremTwoIsNotApplicableWhenTheTruncationErrorExceedsTheMargin) {
  // 1000 layers: delta_1 = 2 l/(k0 pi^2)(pi^2/6 - 1) = 0.0467 > eps_a = 1.65e-4 (scipy-free:
  // the closed form of the tail), so the theorem says nothing.
  const auto r = compute_margins(PowderBedTf(kPa12, 0.1), kPaperPi, 1, -0.01, 20);
  EXPECT_NEAR(r.hinf_g_minus_gn, 2 * 0.1 / (0.28 * M_PI * M_PI) * (M_PI * M_PI / 6 - 1), 1e-12);
  EXPECT_FALSE(r.theorem2_applicable);
  EXPECT_FALSE(r.theorem2_holds);
  EXPECT_EQ(r.nyquist_rhp_poles_g, 0);
}

TEST(RobustMargin, BothWaysAgreeOnADeepBedWithManyModes) {
  // 100 layers: the modal poles come down to the loop crossover; the Hamiltonian on G_60 plus
  // the one-pole tail must still match the sweep of the exact G (and the sweep of its own
  // state-space realisation). Under sanitizers: 30 layers, G_24.
  const PowderBedTf g(kPa12, kDeepBedM);
  const auto r = compute_margins(g, kPaperPi, 1, -0.01, kDeepBedModes);
  EXPECT_NEAR(r.margin_on_g_hamiltonian, r.margin_on_g_sweep, 1e-7 * r.margin_on_g_sweep);
  EXPECT_NEAR(r.margin_on_gn_hamiltonian, r.margin_on_gn_sweep, 1e-8 * r.margin_on_gn_sweep);
  const auto t =
      control_sensitivity(modal_realization(g, kDeepBedModes, TailModel::one_pole), kPaperPi);
  SweepOptions o;
  o.w_min_rad_s = 1e-6;
  o.w_max_rad_s = 1e6;
  const auto pk = sweep_peak([&](std::complex<double> s) { return amctl::control::transfer_siso(t, s); }, o);
  EXPECT_NEAR(1.0 / pk.peak, r.margin_on_g_sweep, 1e-8 * r.margin_on_g_sweep);
}

TEST(RobustMargin, MarginCannotExceedOneOverKp) {
  // |C S| -> kp as w -> inf because G -> 0, so 1/kp is a ceiling for every plant and l.
  const PidGains pi = PidGains::standard(0.3, 2.0);
  const PowderBedTf g(kPa12, 1e-6);
  const auto r = compute_margins(g, pi, 1, -0.01, kHamiltonianModes);
  EXPECT_LE(r.margin_on_gn_sweep, 1.0 / 0.3 + 1e-12);
  EXPECT_LE(r.margin_on_g_sweep, 1.0 / 0.3 + 1e-12);
}

TEST(RobustMargin, HamiltonianNormOfAFirstOrderLagIsItsDcGain) {
  const auto s = amctl::control::StateSpace::siso(Eigen::MatrixXd::Constant(1, 1, -2.0),
                                                  Eigen::VectorXd::Constant(1, 1.0),
                                                  Eigen::RowVectorXd::Constant(1, 3.0));
  EXPECT_NEAR(hinf_norm_hamiltonian(s), 1.5, 1e-8);
  // A lightly damped resonance 1/(s^2 + 2 z s + 1): peak 1/(2 z sqrt(1 - z^2)).
  const double z = 0.05;
  const auto r = amctl::control::StateSpace::siso(Eigen::MatrixXd{{0, 1}, {-1, -2 * z}},
                                                  Eigen::VectorXd{{0, 1}},
                                                  Eigen::RowVectorXd{{1, 0}});
  EXPECT_NEAR(hinf_norm_hamiltonian(r), 1.0 / (2 * z * std::sqrt(1 - z * z)), 1e-7);
}

TEST(RobustMargin, HankelBestMarginIsResidueOverTwoBeta) {
  const PowderBedTf g(kPa12, 1e-4);
  EXPECT_NEAR(hankel_best_margin(g, -0.01), 5.135368308615e-03 / 0.02, 1e-12);
  EXPECT_THROW((void)hankel_best_margin(g, 0.0), amctl::Error);
}

TEST(RobustMargin, RejectsUnrealisablePi) {
  const PowderBedTf g(kPa12, 1e-4);
  // Gains that cannot even be built (Ti <= 0, kp < 0) and gains that are not a realisable PI
  // (kp = 0, no integral action, a derivative term) are all rejected.
  EXPECT_THROW((void)compute_margins(g, PidGains::standard(0.3, 0.0), 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, PidGains::standard(-1.0, 0.5), 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, PidGains::standard(0.0, 0.5), 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, PidGains::parallel(0.3, 0.0), 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, PidGains::standard(0.3, 0.5, 0.1), 1), amctl::Error);
  EXPECT_THROW((void)compute_margins(g, kPaperPi, 0), amctl::Error);
  auto message_of = [](const auto& f) -> std::string {
    try {
      f();
    } catch (const amctl::Error& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected amctl::Error";
    return "";
  };
  EXPECT_NE(message_of([] { (void)PidGains::standard(0.3, -1.0); }).find("Ti"), std::string::npos);
  EXPECT_NE(message_of([&] { (void)compute_margins(g, PidGains::parallel(0.3, 0.0), 1); })
                .find("Ti (PI integral time)"),
            std::string::npos);
  // The study behind `thermal sls-margins` names Ti before any gains are built.
  EXPECT_NE(message_of([] {
              MarginStudyOptions o;
              o.ti_s = -1.0;
              (void)run_margin_study(o);
            }).find("Ti (PI integral time)"),
            std::string::npos);
}

TEST(RobustMargin, NyquistCountFindsTheUnstablePolesOfAThirdOrderLoop) {
  // L = K/(s + 1)^3: stable for K < 8; for K = 27 the roots of (s + 1)^3 + 27 are
  // s = -1 - 3 (cube roots of unity): -4 and 0.5 +/- 2.598j, two in the right half plane.
  auto loop = [](double k) {
    return [k](std::complex<double> s) { return k / ((s + 1.0) * (s + 1.0) * (s + 1.0)); };
  };
  EXPECT_EQ(nyquist_closed_loop_rhp_poles(loop(4.0)), 0);
  EXPECT_EQ(nyquist_closed_loop_rhp_poles(loop(27.0)), 2);
  // An open-loop unstable plant 1/(s - 1) with gain 2 is stabilised: Z = N + P = -1 + 1 = 0.
  auto unstable = [](std::complex<double> s) { return 2.0 / (s - 1.0); };
  EXPECT_EQ(nyquist_closed_loop_rhp_poles(unstable, 1), 0);
}

TEST(RobustMargin, PaperPiStabilisesTheExactIrrationalPlant) {
  const auto r = compute_margins(PowderBedTf(kPa12, 1e-4), kPaperPi, 1, -0.01, kHamiltonianModes);
  EXPECT_EQ(r.nyquist_rhp_poles_g, 0);
  // With a pure delay of 100 s the same PI no longer stabilises G (phase lag at the 0.055 rad/s
  // crossover is 5.5 rad): the count must become positive.
  const PowderBedTf g(kPa12, 1e-4);
  auto delayed = [&](std::complex<double> s) {
    return g.eval(s) * kPaperPi.transfer(s) * std::exp(-100.0 * s);
  };
  EXPECT_GT(nyquist_closed_loop_rhp_poles(delayed, 0, 1e-9, 1e3), 0);
}

TEST(RobustMargin, LoopComputationsRejectAMimoPlant) {
  const amctl::control::StateSpace two_inputs(Eigen::MatrixXd{{-1.0}}, Eigen::MatrixXd{{1.0, 1.0}},
                                              Eigen::MatrixXd{{1.0}}, Eigen::MatrixXd{{0.0, 0.0}});
  EXPECT_THROW((void)control_sensitivity(two_inputs, kPaperPi), amctl::Error);
  EXPECT_THROW((void)hinf_norm_hamiltonian(two_inputs), amctl::Error);
}
