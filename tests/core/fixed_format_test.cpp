// append_fixed against hand-written strings and, on random values, against the exact decimal
// conversion of fmt ("{:.Nf}"), read back: within one unit of the last decimal.
#include <cmath>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "amctl/core/fixed_format.hpp"

namespace amctl {
namespace {

std::string fixed(double v, int d) {
  std::string s;
  append_fixed(s, v, d);
  return s;
}

TEST(FixedFormat, HandWrittenCases) {
  EXPECT_EQ(fixed(0.25, 9), "0.25");
  EXPECT_EQ(fixed(10.0, 9), "10");
  EXPECT_EQ(fixed(-1e-12, 9), "0");
  EXPECT_EQ(fixed(-0.0, 3), "0");
  EXPECT_EQ(fixed(-2.5, 0), "-3");  // half away from zero
  EXPECT_EQ(fixed(123.456789, 3), "123.457");
  EXPECT_EQ(fixed(-0.000001, 6), "-0.000001");
  EXPECT_EQ(fixed(1.0000000004, 9), "1");
  EXPECT_EQ(fixed(1.0000000006, 9), "1.000000001");
  EXPECT_EQ(fixed(1e10, 9), "10000000000");  // beyond 9e9: shortest form, still no exponent
  EXPECT_EQ(fixed(std::nan(""), 3), "nan");
  EXPECT_EQ(fixed(-INFINITY, 3), "-inf");
}

TEST(FixedFormat, RandomValuesAgreeWithExactDecimalConversion) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> mag(-6.0, 4.0);
  for (int i = 0; i < 200000; ++i) {
    const double v = (rng() & 1 ? -1 : 1) * std::pow(10.0, mag(rng));
    const int d = static_cast<int>(rng() % 10);
    const double got = std::stod(fixed(v, d));
    const double ref = std::stod(fmt::format("{:.{}f}", v, d));
    ASSERT_LE(std::abs(got - ref), std::pow(10.0, -d) * (1 + 1e-9)) << v << " " << d;
    ASSERT_LE(std::abs(got - v), 0.5 * std::pow(10.0, -d) * (1 + 1e-6) + 1e-15 * std::abs(v)) << v << " " << d;
  }
}

}  // namespace
}  // namespace amctl
