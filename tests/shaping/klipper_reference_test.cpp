// amctl's shapers and measures against the numbers Klipper's own Python functions give
// (tests/reference/shaping/klipper_shapers.json; how it was made: README.md beside it).
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {
namespace {

nlohmann::json reference() {
  std::ifstream in(std::string(AMCTL_SOURCE_DIR) + "/tests/reference/shaping/klipper_shapers.json");
  return nlohmann::json::parse(in);
}

double rel(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

TEST(KlipperReference, EveryShaperEqualsKlipper) {
  const auto ref = reference();
  const std::vector<double> res_freqs = ref.at("residual_freqs_hz").get<std::vector<double>>();
  double max_amp = 0.0, max_time = 0.0, max_smooth_rel = 0.0, max_accel_rel = 0.0;
  double max_vibr = 0.0, max_smooth_abs = 0.0, max_accel_abs = 0.0;
  std::size_t cases = 0;
  for (const auto& c : ref.at("cases")) {
    const std::string type = c.at("type");
    const double f = c.at("freq_hz");
    const double z = c.at("damping_ratio");
    const std::string what = fmt::format("{} {} Hz zeta {}", type, f, z);
    const Shaper s = make_shaper(type, f, z);
    const auto A = c.at("amplitudes").get<std::vector<double>>();
    const auto T = c.at("times_s").get<std::vector<double>>();
    ASSERT_EQ(s.amplitudes.size(), A.size()) << what;
    for (std::size_t i = 0; i < A.size(); ++i) {
      EXPECT_NEAR(s.amplitudes[i], A[i], 1e-9) << what;
      EXPECT_NEAR(s.times_s[i], T[i], 1e-9) << what;
      max_amp = std::max(max_amp, std::abs(s.amplitudes[i] - A[i]));
      max_time = std::max(max_time, std::abs(s.times_s[i] - T[i]));
    }
    for (const auto& sm : c.at("smoothing_mm")) {
      const double v = smoothing_mm(s, sm.at("accel_mm_s2"), sm.at("scv_mm_s"));
      const double k = sm.at("value");
      EXPECT_LE(rel(v, k), 1e-6) << what;
      max_smooth_rel = std::max(max_smooth_rel, rel(v, k));
      max_smooth_abs = std::max(max_smooth_abs, std::abs(v - k));
    }
    for (const auto& ma : c.at("max_accel_mm_s2")) {
      const double v = max_accel_mm_s2(s, ma.at("scv_mm_s"));
      const double k = ma.at("value");
      EXPECT_LE(rel(v, k), 1e-6) << what;
      max_accel_rel = std::max(max_accel_rel, rel(v, k));
      max_accel_abs = std::max(max_accel_abs, std::abs(v - k));
    }
    std::vector<double> freqs = res_freqs;
    freqs.push_back(f);
    for (const auto& rv : c.at("residual_vibration")) {
      const auto curve = vibration_curve(s, freqs, rv.at("test_damping_ratio"));
      const auto k = rv.at("values").get<std::vector<double>>();
      ASSERT_EQ(k.size(), freqs.size());
      for (std::size_t i = 0; i < k.size(); ++i) {
        EXPECT_NEAR(curve.remaining_fraction[i], k[i], 1e-9) << what << " at " << freqs[i];
        max_vibr = std::max(max_vibr, std::abs(curve.remaining_fraction[i] - k[i]));
      }
    }
    ++cases;
  }
  EXPECT_GT(cases, 200u);
  // The agreement figures docs/shaping.md reports.
  std::cout << fmt::format(
      "klipper agreement over {} cases: amplitudes {:.3g}, times {:.3g} s, smoothing {:.3g} mm "
      "({:.3g} rel), max accel {:.3g} mm/s^2 ({:.3g} rel), residual vibration {:.3g}\n",
      cases, max_amp, max_time, max_smooth_abs, max_smooth_rel, max_accel_abs, max_accel_rel,
      max_vibr);
}

TEST(KlipperReference, GeneralisedMzvIsAcceptedAndRefusedAsKlipperDoes) {
  // mzv(n, t) over n = 3..12 and t in steps of 1/8: Klipper refuses short trains as
  // negative-valued and long ones as ill-formed (a pivot below 1e-10 in its elimination);
  // amctl solves the normal equations in the same order, so the verdicts and the impulses
  // (to the bit, measured) are the same.
  const auto ref = reference();
  std::size_t ok = 0, refused = 0;
  double max_amp = 0.0;
  for (const auto& g : ref.at("mzv_grid")) {
    const std::string type = g.at("type");
    const std::string result = g.at("result");
    if (result != "ok") {
      try {
        (void)make_shaper(type, g.at("freq_hz"), g.at("damping_ratio"));
        ADD_FAILURE() << type << " should be refused as " << result;
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(result), std::string::npos) << type << ": " << e.what();
      }
      ++refused;
      continue;
    }
    const Shaper s = make_shaper(type, g.at("freq_hz"), g.at("damping_ratio"));
    const auto A = g.at("amplitudes").get<std::vector<double>>();
    const auto T = g.at("times_s").get<std::vector<double>>();
    ASSERT_EQ(s.amplitudes.size(), A.size()) << type;
    for (std::size_t i = 0; i < A.size(); ++i) {
      EXPECT_NEAR(s.amplitudes[i], A[i], 1e-9) << type;
      EXPECT_NEAR(s.times_s[i], T[i], 1e-9) << type;
      max_amp = std::max(max_amp, std::abs(s.amplitudes[i] - A[i]));
    }
    ++ok;
  }
  EXPECT_EQ(ok, 193u);
  EXPECT_EQ(refused, 53u);
  std::cout << fmt::format("generalised mzv: {} accepted (amplitudes within {:.3g}), {} refused\n",
                           ok, max_amp, refused);
}

}  // namespace
}  // namespace amctl::shaping
