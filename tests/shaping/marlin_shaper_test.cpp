// Marlin FT_MOTION's shapers against closed forms derived by hand (docs/shaping.md, "Marlin's
// definitions"), and the differences from Klipper's of the same name.
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/report.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {
namespace {

constexpr double kPi = std::numbers::pi;

double K_of(double zeta) { return std::exp(-zeta * kPi / std::sqrt(1.0 - zeta * zeta)); }

Shaper marlin(std::string_view type, double f, double zeta, double rate_hz = 0.0) {
  return make_shaper(parse_shaper_spec(type, Firmware::marlin, rate_hz), f, zeta);
}
Shaper klipper(std::string_view type, double f, double zeta) {
  return make_shaper(parse_shaper_spec(type, Firmware::klipper), f, zeta);
}

/// Residual vibration written out directly (a second implementation, not measures.cpp):
/// |sum A_i exp(-zeta w (T_last - T_i)) exp(i w_d T_i)| / sum A_i.
double residual(const Shaper& s, double f, double zeta) {
  const double w = 2.0 * kPi * f, wd = w * std::sqrt(1.0 - zeta * zeta);
  std::complex<double> h = 0.0;
  double sum = 0.0;
  for (std::size_t i = 0; i < s.amplitudes.size(); ++i) {
    h += s.amplitudes[i] * std::exp(-zeta * w * (s.times_s.back() - s.times_s[i])) *
         std::polar(1.0, wd * s.times_s[i]);
    sum += s.amplitudes[i];
  }
  return std::abs(h) / sum;
}

TEST(MarlinShaper, MzvDecaysByKWhereKlipperDecaysByKToTheThreeQuarters) {
  for (double zeta : {0.0, 0.05, 0.1, 0.2, 0.4}) {
    const double K = K_of(zeta), t_d = 1.0 / (40.0 * std::sqrt(1.0 - zeta * zeta));
    const Shaper m = marlin("mzv", 40.0, zeta);
    ASSERT_EQ(m.amplitudes.size(), 3U);
    EXPECT_NEAR(m.amplitudes[1] / m.amplitudes[0], std::numbers::sqrt2 * K, 1e-14);
    EXPECT_NEAR(m.amplitudes[2] / m.amplitudes[0], K * K, 1e-14);
    EXPECT_NEAR(m.times_s[1], 0.375 * t_d, 1e-15);
    EXPECT_NEAR(m.times_s[2], 0.75 * t_d, 1e-15);
    // The residual at its own frequency, by hand: the three terms are K^1.5, sqrt2 K^1.75
    // e^{i 3pi/4} and K^2 e^{i 3pi/2}, so
    //   V = K^1.5 (1 - K^0.25) sqrt(1 + K^0.5) / (1 + sqrt2 K + K^2).
    const double closed = std::pow(K, 1.5) * (1.0 - std::pow(K, 0.25)) * std::sqrt(1.0 + std::sqrt(K)) /
                          (1.0 + std::numbers::sqrt2 * K + K * K);
    EXPECT_NEAR(remaining_vibration(m, 40.0, zeta), closed, 1e-14) << zeta;
    EXPECT_NEAR(residual(m, 40.0, zeta), closed, 1e-14) << zeta;
    // Klipper's leaves nothing.
    EXPECT_LT(remaining_vibration(klipper("mzv", 40.0, zeta), 40.0, zeta), 1e-14);
  }
  // The figure docs/shaping.md quotes: zeta = 0.1, 2.51 % left.
  EXPECT_NEAR(remaining_vibration(marlin("mzv", 40.0, 0.1), 40.0, 0.1), 0.0251096, 1e-7);
}

TEST(MarlinShaper, ZvFamilyEqualsKlippersOnceNormalised) {
  for (const char* type : {"zv", "zvd"}) {
    for (double zeta : {0.0, 0.1, 0.3}) {
      const Shaper m = marlin(type, 37.0, zeta), k = klipper(type, 37.0, zeta);
      ASSERT_EQ(m.amplitudes.size(), k.amplitudes.size());
      const auto a = m.normalized_amplitudes(), b = k.normalized_amplitudes();
      for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_NEAR(a[i], b[i], 1e-15);
        EXPECT_NEAR(m.times_s[i], k.times_s[i], 1e-16);
      }
    }
  }
  // zvdd / zvddd without a firmware are Marlin's, with exact times.
  const ShaperSpec s = parse_shaper_spec("zvdd");
  EXPECT_EQ(s.firmware, Firmware::marlin);
  EXPECT_EQ(s.sample_rate_hz, 0.0);
}

TEST(MarlinShaper, EiTypesAreTheUndampedClosedFormsScaledByKToTheI) {
  // Impulse i at i t_d / 2 with amplitude a_i K^i: at the design frequency every term has
  // the decay K^(n-1) and the phase (-1)^i, so V = K^(n-1) |sum (-1)^i a_i| / sum a_i K^i.
  for (double V : {0.05, 0.1, 0.2}) {
    const double X = std::cbrt(V * V * (std::sqrt(1.0 - V * V) + 1.0));
    const double h2 = (3.0 * X * X + 2.0 * X + 3.0 * V * V) / (16.0 * X);
    const double h3 = (1.0 + 3.0 * V + 2.0 * std::sqrt(2.0 * (V * V + V))) / 16.0;
    const std::vector<std::pair<std::string, std::vector<double>>> undamped = {
        {"ei", {(1.0 + V) / 4.0, (1.0 - V) / 2.0, (1.0 + V) / 4.0}},
        {"2hump_ei", {h2, 0.5 - h2, 0.5 - h2, h2}},
        {"3hump_ei", {h3, (1.0 - V) / 4.0, 1.0 - 2.0 * (h3 + (1.0 - V) / 4.0), (1.0 - V) / 4.0, h3}}};
    for (const auto& [name, a] : undamped) {
      for (double zeta : {0.0, 0.1, 0.25}) {
        const std::string type = fmt::format("{}(v_tol={})", name, V);
        const Shaper m = marlin(type, 45.0, zeta);
        const double K = K_of(zeta), t_d = 1.0 / (45.0 * std::sqrt(1.0 - zeta * zeta));
        ASSERT_EQ(m.amplitudes.size(), a.size()) << type;
        double alt = 0.0, sum = 0.0, Ki = 1.0;
        for (std::size_t i = 0; i < a.size(); ++i) {
          EXPECT_NEAR(m.amplitudes[i], a[i] * Ki, 1e-14) << type << " " << i;
          EXPECT_NEAR(m.times_s[i], 0.5 * static_cast<double>(i) * t_d, 1e-15) << type;
          alt += (i % 2 == 0 ? 1.0 : -1.0) * a[i];
          sum += a[i] * Ki;
          Ki *= K;
        }
        const double expect = std::pow(K, static_cast<double>(a.size() - 1)) * std::abs(alt) / sum;
        EXPECT_NEAR(remaining_vibration(m, 45.0, zeta), expect, 1e-14) << type << " " << zeta;
      }
    }
  }
  // Undamped: EI and 3HEI leave exactly V at the design frequency, 2HEI nothing.
  EXPECT_NEAR(remaining_vibration(marlin("ei", 45.0, 0.0), 45.0, 0.0), 0.05, 1e-15);
  EXPECT_NEAR(remaining_vibration(marlin("3hump_ei", 45.0, 0.0), 45.0, 0.0), 0.05, 1e-15);
  EXPECT_LT(remaining_vibration(marlin("2hump_ei", 45.0, 0.0), 45.0, 0.0), 1e-15);
}

TEST(MarlinShaper, TimesAreRoundedToItsTrajectoryGrid) {
  // 40 Hz, zeta 0.1: t_d = 25.126 ms; MZV's first echo 0.375 t_d = 9.42 ms -> 9 samples of 1 ms.
  const Shaper m = marlin("mzv", 40.0, 0.1, kMarlinFtmSampleRateHz);
  ASSERT_EQ(m.times_s.size(), 3U);
  EXPECT_DOUBLE_EQ(m.times_s[1], 0.009);
  EXPECT_DOUBLE_EQ(m.times_s[2], 0.018);
  // ZVD at 40 Hz, zeta 0.1: 0.5 t_d = 12.56 ms -> 13 samples.
  const Shaper z = marlin("zvd", 40.0, 0.1, kMarlinFtmSampleRateHz);
  EXPECT_DOUBLE_EQ(z.times_s[1], 0.013);
  EXPECT_DOUBLE_EQ(z.times_s[2], 0.026);
  // The default of the firmware-named parse is the 1 kHz grid.
  EXPECT_EQ(parse_shaper_spec("zv", Firmware::marlin).sample_rate_hz, kMarlinFtmSampleRateHz);
  // A frequency so high the first echo rounds to no sample at all is refused.
  EXPECT_THROW((void)marlin("mzv", 900.0, 0.1, 1000.0), Error);
}

TEST(MarlinShaper, EachFirmwareRefusesWhatItLacksNamingWhatEachAccepts) {
  try {
    (void)parse_shaper_spec("zvdd", Firmware::klipper);
    FAIL();
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("'zvdd' is not a klipper shaper"), std::string::npos) << m;
    EXPECT_NE(m.find("expected one of zv, mzv, zvd, ei, 2hump_ei, 3hump_ei"), std::string::npos) << m;
    EXPECT_NE(m.find("marlin offers zv, zvd, zvdd, zvddd, ei, 2hump_ei, 3hump_ei, mzv"), std::string::npos) << m;
  }
  EXPECT_THROW((void)parse_shaper_spec("mzv(n=4, t=0.9)", Firmware::marlin), Error);
  EXPECT_THROW((void)parse_shaper_spec("2hump_ei(v_tol=0.1)", Firmware::klipper), Error);
  EXPECT_THROW((void)make_shaper("3hump_ei(v_tol=0.1)", 40.0, 0.1), Error);  // Klipper's by default
  EXPECT_THROW((void)parse_firmware("prusa"), Error);
  EXPECT_EQ(parse_firmware(" Marlin "), Firmware::marlin);
}

TEST(MarlinShaper, ShowReportsTheOtherFirmwaresDefinition) {
  ShaperReportOptions o;
  o.type = "mzv";
  o.freq_hz = 40.0;
  o.damping_ratio = 0.1;
  o.firmware = Firmware::marlin;
  o.marlin_sample_rate_hz = 0.0;
  const ShaperReport r = shaper_report(o);
  ASSERT_TRUE(r.compared_with.has_value());
  EXPECT_EQ(r.compared_with->shaper.spec.firmware, Firmware::klipper);
  EXPECT_FALSE(r.compared_with->same());
  EXPECT_LT(r.compared_with->residual_at_design, 1e-14);
  EXPECT_NEAR(r.residual_at_design, 0.0251096, 1e-7);
  EXPECT_EQ(r.compared_with->max_time_difference_s, 0.0);
  const Json j = to_json(r);
  EXPECT_EQ(j["firmware"], "marlin");
  EXPECT_EQ(j["compared_with"]["firmware"], "klipper");
  EXPECT_TRUE(j["klipper_max_damping_ratio"].is_null());
  // ZV: the same shaper in both firmwares (exact times).
  o.type = "zv";
  EXPECT_TRUE(shaper_report(o).compared_with->same());
  // zvdd: Klipper has none.
  o.type = "zvdd";
  EXPECT_FALSE(shaper_report(o).compared_with.has_value());
}

}  // namespace
}  // namespace amctl::shaping
