// The shared numerics against independent computations: a direct DFT, numpy's Kaiser window
// and Bessel function, closed-form minima and exactly fitted data.
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/numerics/fft.hpp"
#include "amctl/numerics/least_squares.hpp"
#include "amctl/numerics/scalar_search.hpp"

namespace amctl::numerics {
namespace {

using cd = std::complex<double>;

std::vector<cd> direct_dft(const std::vector<double>& x) {
  const std::size_t n = x.size();
  std::vector<cd> out(n / 2 + 1);
  for (std::size_t k = 0; k < out.size(); ++k) {
    cd s(0.0, 0.0);
    for (std::size_t j = 0; j < n; ++j) {
      const double ph = -2.0 * std::numbers::pi * static_cast<double>(k * j % n) / static_cast<double>(n);
      s += x[j] * cd(std::cos(ph), std::sin(ph));
    }
    out[k] = s;
  }
  return out;
}

TEST(RealFft, ForwardEqualsTheDirectSumAndInverseGivesNTimesTheSignal) {
  for (const std::size_t n : {1u, 2u, 7u, 64u, 100u, 257u}) {
    std::mt19937 rng(static_cast<unsigned>(n));
    std::normal_distribution<double> g;
    std::vector<double> x(n);
    for (double& v : x) v = g(rng);
    RealFft fft(n);
    ASSERT_EQ(fft.bins(), n / 2 + 1);
    std::copy(x.begin(), x.end(), fft.signal().begin());
    fft.forward();
    const auto want = direct_dft(x);
    for (std::size_t k = 0; k < fft.bins(); ++k) {
      EXPECT_NEAR(fft.spectrum()[k].real(), want[k].real(), 1e-11 * static_cast<double>(n)) << n << " " << k;
      EXPECT_NEAR(fft.spectrum()[k].imag(), want[k].imag(), 1e-11 * static_cast<double>(n)) << n << " " << k;
    }
    EXPECT_EQ(fft.signal()[n - 1], x[n - 1]);  // forward keeps the signal
    fft.inverse();
    for (std::size_t j = 0; j < n; ++j) EXPECT_NEAR(fft.signal()[j], static_cast<double>(n) * x[j], 1e-11 * static_cast<double>(n));
  }
}

TEST(RealFft, ACosineAtABinIsHalfNThere) {
  const std::size_t n = 128;
  RealFft fft(n);
  for (std::size_t j = 0; j < n; ++j) fft.signal()[j] = std::cos(2.0 * std::numbers::pi * 5.0 * static_cast<double>(j) / n);
  fft.forward();
  for (std::size_t k = 0; k < fft.bins(); ++k) EXPECT_NEAR(std::abs(fft.spectrum()[k]), k == 5 ? 64.0 : 0.0, 1e-12);
}

TEST(Kaiser, EqualsNumpy) {
  // numpy.i0(1), numpy.i0(6), numpy.kaiser(7, 6.0) (numpy 1.24).
  EXPECT_NEAR(bessel_i0(1.0), 1.2660658777520082, 1e-15);
  EXPECT_NEAR(bessel_i0(6.0), 67.23440697647798, 1e-12);
  const std::vector<double> want = {0.014873337104763207, 0.2537060802713222, 0.7318954153978208, 1.0,
                                    0.7318954153978208,   0.2537060802713222, 0.014873337104763207};
  const auto w = kaiser_window(7, 6.0);
  ASSERT_EQ(w.size(), want.size());
  for (std::size_t i = 0; i < w.size(); ++i) EXPECT_NEAR(w[i], want[i], 1e-15);
  EXPECT_EQ(kaiser_window(1, 6.0), std::vector<double>{1.0});
}

TEST(WelchSegments, EachSegmentIsTheDftOfItsWindowedDeviationFromItsMean) {
  const std::size_t m = 16;
  std::vector<double> window(m);
  for (std::size_t i = 0; i < m; ++i) window[i] = 0.5 + 0.25 * std::sin(static_cast<double>(i));
  WelchSegments welch(m, window);
  EXPECT_EQ(welch.step(), 8u);
  EXPECT_EQ(welch.segments_in(15), 0u);
  EXPECT_EQ(welch.segments_in(16), 1u);
  EXPECT_EQ(welch.segments_in(40), 4u);  // starts 0, 8, 16, 24
  double energy = 0.0;
  for (const double w : window) energy += w * w;
  EXPECT_DOUBLE_EQ(welch.window_energy(), energy);
  std::vector<double> x(40);
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = 3.0 + std::cos(0.7 * static_cast<double>(i * i));
  for (std::size_t s = 0; s < 4; ++s) {
    const double* seg = x.data() + s * welch.step();
    double mean = 0.0;
    for (std::size_t i = 0; i < m; ++i) mean += seg[i] / static_cast<double>(m);
    std::vector<double> y(m);
    for (std::size_t i = 0; i < m; ++i) y[i] = window[i] * (seg[i] - mean);
    const auto want = direct_dft(y);
    const auto got = welch.transform(seg);
    for (std::size_t k = 0; k < welch.bins(); ++k) EXPECT_LT(std::abs(got[k] - want[k]), 1e-12);
  }
}

TEST(GoldenSection, BracketsTheMinimumOfAParabolaInTheExpectedSteps) {
  int calls = 0;
  GoldenSectionStop stop;
  stop.width = 1e-6;
  const auto br = golden_section_minimize(
      [&](double x) {
        ++calls;
        return (x - 2.0) * (x - 2.0);
      },
      0.0, 5.0, stop);
  EXPECT_LE(br.a, 2.0);
  EXPECT_GE(br.b, 2.0);
  EXPECT_LE(br.b - br.a, 1e-6);
  // Width 5 g^k <= 1e-6: k = ceil(ln(5e6) / ln(1/g)) = 33 steps after the two first points.
  EXPECT_EQ(br.evaluations, 35u);
  EXPECT_EQ(calls, 35);
  GoldenSectionStop fixed;
  fixed.max_steps = 4;
  EXPECT_EQ(golden_section_minimize([](double x) { return std::abs(x); }, -1.0, 3.0, fixed).evaluations, 6u);
}

TEST(LevenbergMarquardt, FitsAnExponentialDecayExactly) {
  // y = 3 exp(-0.7 t) sampled at t = 0 .. 4; start far away.
  std::vector<double> t, y;
  for (int i = 0; i <= 20; ++i) {
    t.push_back(0.2 * i);
    y.push_back(3.0 * std::exp(-0.7 * t.back()));
  }
  auto residuals = [&](const Eigen::VectorXd& p) {
    Eigen::VectorXd r(static_cast<Eigen::Index>(t.size()));
    for (std::size_t i = 0; i < t.size(); ++i) r(static_cast<Eigen::Index>(i)) = p(0) * std::exp(-p(1) * t[i]) - y[i];
    return r;
  };
  auto jacobian = [&](const Eigen::VectorXd& p) {
    Eigen::MatrixXd j(static_cast<Eigen::Index>(t.size()), 2);
    for (std::size_t i = 0; i < t.size(); ++i) {
      const auto ii = static_cast<Eigen::Index>(i);
      j(ii, 0) = std::exp(-p(1) * t[i]);
      j(ii, 1) = -p(0) * t[i] * std::exp(-p(1) * t[i]);
    }
    return j;
  };
  Eigen::VectorXd p(2);
  p << 1.0, 3.0;
  int accepted = 0;
  LevenbergMarquardtOptions o;
  const auto res = levenberg_marquardt(
      p, residuals(p), residuals, jacobian, [](Eigen::VectorXd&) {},
      [&](const Eigen::VectorXd&, const Eigen::VectorXd&) { ++accepted; }, o);
  EXPECT_NEAR(p(0), 3.0, 1e-9);
  EXPECT_NEAR(p(1), 0.7, 1e-9);
  EXPECT_LT(res.cost, 1e-20);
  EXPECT_EQ(res.accepted_steps, accepted);
  EXPECT_NE(res.stop, LevenbergMarquardtStop::max_iterations);
}

TEST(LevenbergMarquardt, KeepsBoundsAndHoldsAParameterWithNoEffect) {
  // r = (p0 - 5, 0 * p1): the minimum p0 = 5 lies outside the bound p0 <= 2; p1 has no effect.
  auto residuals = [](const std::array<double, 2>& p) {
    Eigen::VectorXd r(2);
    r << p[0] - 5.0, 0.0 * p[1];
    return r;
  };
  auto jacobian = [](const std::array<double, 2>&) {
    Eigen::MatrixXd j(2, 2);
    j << 1.0, 0.0, 0.0, 0.0;
    return j;
  };
  std::array<double, 2> p{0.0, 0.25};
  LevenbergMarquardtOptions o;
  o.hold_flat_parameters = true;
  const auto res = levenberg_marquardt(p, residuals(p), residuals, jacobian,
                                       [](std::array<double, 2>& q) { q[0] = std::min(q[0], 2.0); }, o);
  EXPECT_EQ(p[0], 2.0);
  EXPECT_EQ(p[1], 0.25);
  EXPECT_DOUBLE_EQ(res.cost, 9.0);
  EXPECT_EQ(res.stop, LevenbergMarquardtStop::no_descent);
}

}  // namespace
}  // namespace amctl::numerics
