// StateSpace validation and G(s) = C (sI - A)^-1 B + D against transfer functions worked out
// by hand.
#include "amctl/control/state_space.hpp"

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::control {
namespace {

using cd = std::complex<double>;
constexpr double kPi = std::numbers::pi;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected amctl::Error";
  return "";
}

// m x'' + c x' + k x = F, state [x, x'], output x: G(s) = 1/(m s^2 + c s + k).
StateSpace mass_spring_damper(double m, double c, double k) {
  return StateSpace(Eigen::MatrixXd{{0.0, 1.0}, {-k / m, -c / m}},
                    Eigen::MatrixXd{{0.0}, {1.0 / m}}, Eigen::MatrixXd{{1.0, 0.0}},
                    Eigen::MatrixXd{{0.0}});
}

TEST(StateSpace, RejectsBadShapesAndNonFiniteEntriesNamingTheMatrix) {
  const Eigen::MatrixXd a2 = Eigen::MatrixXd::Identity(2, 2);
  const Eigen::MatrixXd b2 = Eigen::MatrixXd::Ones(2, 1);
  const Eigen::MatrixXd c2 = Eigen::MatrixXd::Ones(1, 2);
  const Eigen::MatrixXd d1 = Eigen::MatrixXd::Zero(1, 1);
  EXPECT_NE(error_of([&] { (void)StateSpace(Eigen::MatrixXd::Ones(2, 3), b2, c2, d1); })
                .find("A must be square"),
            std::string::npos);
  const Eigen::MatrixXd b3 = Eigen::MatrixXd::Ones(3, 1), c3 = Eigen::MatrixXd::Ones(1, 3);
  const Eigen::MatrixXd d21 = Eigen::MatrixXd::Zero(2, 1);
  EXPECT_NE(error_of([&] { (void)StateSpace(a2, b3, c2, d1); }).find("B must"), std::string::npos);
  EXPECT_NE(error_of([&] { (void)StateSpace(a2, b2, c3, d1); }).find("C must"), std::string::npos);
  EXPECT_NE(error_of([&] { (void)StateSpace(a2, b2, c2, d21); }).find("D must"), std::string::npos);
  Eigen::MatrixXd bad = a2;
  bad(1, 0) = std::nan("");
  EXPECT_NE(error_of([&] { (void)StateSpace(bad, b2, c2, d1); }).find("A(1, 0) must be finite"),
            std::string::npos);
  EXPECT_THROW(StateSpace::siso(a2, Eigen::VectorXd::Ones(2), Eigen::RowVectorXd::Ones(2),
                                std::numeric_limits<double>::infinity()),
               Error);
  const StateSpace ok(a2, b2, c2, d1);
  EXPECT_EQ(ok.states(), 2);
  EXPECT_EQ(ok.inputs(), 1);
  EXPECT_EQ(ok.outputs(), 1);
  EXPECT_TRUE(ok.is_siso());
}

TEST(FrequencyResponse, FirstOrderLagHasGainOverSqrtTwoAndMinus45DegreesAtTheCorner) {
  // G(s) = k/(tau s + 1) as x' = -x/tau + u, y = (k/tau) x; at w = 1/tau:
  // |G| = k/sqrt(2), arg G = -pi/4.
  const double k = 2.0, tau = 0.5;
  const auto g = StateSpace::siso(Eigen::MatrixXd{{-1.0 / tau}}, Eigen::VectorXd{{1.0}},
                                  Eigen::RowVectorXd{{k / tau}});
  const BodePoint p = bode_point(g, 1.0 / tau);
  EXPECT_NEAR(p.magnitude, k / std::sqrt(2.0), 1e-14);
  EXPECT_NEAR(p.magnitude_db, 20.0 * std::log10(k) - 10.0 * std::log10(2.0), 1e-12);
  EXPECT_NEAR(p.phase_rad, -kPi / 4.0, 1e-14);
  // DC gain k, and the -20 dB/decade asymptote k/(w tau) far above the corner.
  EXPECT_NEAR(std::abs(transfer_siso(g, cd(0.0, 0.0))), k, 1e-14);
  EXPECT_NEAR(bode_point(g, 1e6).magnitude, k / (1e6 * tau), 1e-9 * k / (1e6 * tau));
}

TEST(FrequencyResponse, MassSpringDamperAtResonanceIsMinus90DegreesAndOneOverCw) {
  // m = 2 kg, c = 3 N s/m, k = 50 N/m: at w = sqrt(k/m) = 5 rad/s the denominator is
  // k - m w^2 + j c w = 15 j, so G = -j/15 m/N.
  const StateSpace g = mass_spring_damper(2.0, 3.0, 50.0);
  const Eigen::MatrixXcd h = frequency_response(g, 5.0);
  ASSERT_EQ(h.rows(), 1);
  ASSERT_EQ(h.cols(), 1);
  EXPECT_NEAR(h(0, 0).real(), 0.0, 1e-15);
  EXPECT_NEAR(h(0, 0).imag(), -1.0 / 15.0, 1e-15);
  EXPECT_NEAR(bode_point(g, 5.0).phase_rad, -kPi / 2.0, 1e-13);
  // w = 2: 1/(50 - 8 + 6 j) = (42 - 6 j)/1800.
  const cd g2 = transfer_siso(g, cd(0.0, 2.0));
  EXPECT_NEAR(g2.real(), 42.0 / 1800.0, 1e-15);
  EXPECT_NEAR(g2.imag(), -6.0 / 1800.0, 1e-15);
  // At a real s = 1: 1/(2 + 3 + 50).
  EXPECT_NEAR(transfer_siso(g, cd(1.0, 0.0)).real(), 1.0 / 55.0, 1e-15);
}

TEST(FrequencyResponse, MimoEntriesAndFeedthroughAreEachTheirOwnTransferFunction) {
  // Two decoupled lags 1/(s + 1) and 3/(s + 4), plus a feedthrough D(0, 1) = 0.5 from the
  // second input to the first output.
  const StateSpace g(Eigen::MatrixXd{{-1.0, 0.0}, {0.0, -4.0}},
                     Eigen::MatrixXd{{1.0, 0.0}, {0.0, 3.0}},
                     Eigen::MatrixXd{{1.0, 0.0}, {0.0, 1.0}},
                     Eigen::MatrixXd{{0.0, 0.5}, {0.0, 0.0}});
  const cd s(0.0, 2.0);
  const Eigen::MatrixXcd h = transfer_matrix(g, s);
  EXPECT_NEAR(std::abs(h(0, 0) - 1.0 / (s + 1.0)), 0.0, 1e-15);
  EXPECT_NEAR(std::abs(h(1, 1) - 3.0 / (s + 4.0)), 0.0, 1e-15);
  EXPECT_NEAR(std::abs(h(0, 1) - 0.5), 0.0, 1e-15);
  EXPECT_NEAR(std::abs(h(1, 0)), 0.0, 1e-15);
  EXPECT_THROW((void)transfer_siso(g, s), Error);
}

TEST(FrequencyResponse, StaticGainAndPolesAndNonFiniteFrequencies) {
  const StateSpace gain(Eigen::MatrixXd(0, 0), Eigen::MatrixXd(0, 1), Eigen::MatrixXd(1, 0),
                        Eigen::MatrixXd{{4.0}});
  EXPECT_EQ(transfer_siso(gain, cd(0.0, 7.0)), cd(4.0, 0.0));
  const auto lag = StateSpace::siso(Eigen::MatrixXd{{-2.0}}, Eigen::VectorXd{{1.0}},
                                    Eigen::RowVectorXd{{1.0}});
  EXPECT_NE(error_of([&] { (void)transfer_siso(lag, cd(-2.0, 0.0)); }).find("pole"),
            std::string::npos);
  EXPECT_THROW((void)frequency_response(lag, std::nan("")), Error);
}

}  // namespace
}  // namespace amctl::control
