// The `amctl shaper show` report and its JSON form.
#include "amctl/shaping/report.hpp"

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"

namespace amctl::shaping {
namespace {

TEST(ShaperReport, JsonHasTheKeysTheCliPromises) {
  ShaperReportOptions o;
  o.type = "ZV";
  o.freq_hz = 40.0;
  o.damping_ratio = 0.1;
  o.residual_at_hz = {20.0, 40.0, 80.0};
  o.test_damping_ratio = 0.05;
  const ShaperReport r = shaper_report(o);
  const Json j = to_json(r);
  EXPECT_EQ(j.at("type"), "zv");
  EXPECT_EQ(j.at("amplitudes").size(), 2u);
  EXPECT_EQ(j.at("amplitudes")[0].get<double>(), 1.0);
  EXPECT_EQ(j.at("times_s")[1].get<double>(), r.shaper.times_s[1]);
  EXPECT_EQ(j.at("smoothing_mm").get<double>(), smoothing_mm(r.shaper, 5000.0, 5.0));
  EXPECT_EQ(j.at("max_accel_mm_s2").get<double>(), max_accel_mm_s2(r.shaper, 5.0));
  EXPECT_EQ(j.at("test_damping_ratio").get<double>(), 0.05);
  ASSERT_EQ(j.at("residual_vibration").size(), 3u);
  EXPECT_EQ(j.at("residual_vibration")[2].get<double>(), remaining_vibration(r.shaper, 80.0, 0.05));
  EXPECT_EQ(j.at("residual_at_hz")[0].get<double>(), 20.0);
  EXPECT_EQ(j.at("klipper_max_damping_ratio").get<double>(), 0.99);
  EXPECT_TRUE(to_json(shaper_report({.type = "zvdd", .freq_hz = 40.0}))
                  .at("klipper_max_damping_ratio").is_null());
}

TEST(ShaperReport, ResidualDefaultsToTheDesignFrequencyAndDamping) {
  const ShaperReport r = shaper_report({.type = "zvd", .freq_hz = 52.0, .damping_ratio = 0.2});
  ASSERT_EQ(r.residual.freqs_hz.size(), 1u);
  EXPECT_EQ(r.residual.freqs_hz[0], 52.0);
  EXPECT_EQ(r.residual.test_damping_ratio, 0.2);
  EXPECT_LT(r.residual.remaining_fraction[0], 1e-13);
  const std::string text = to_text(r);
  EXPECT_NE(text.find("shaper zvd at 52 Hz, damping ratio 0.2"), std::string::npos) << text;
  EXPECT_NE(text.find("max accel"), std::string::npos);
}

TEST(ShaperReport, BadInputNamesTheParameter) {
  const auto message = [](const ShaperReportOptions& o) -> std::string {
    try {
      (void)shaper_report(o);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message({.type = "zv", .freq_hz = 0.0}).find("freq_hz must be"), std::string::npos);
  EXPECT_NE(message({.type = "zv", .freq_hz = 10.0, .damping_ratio = 1.0}).find("damping_ratio must be"),
            std::string::npos);
  EXPECT_NE(message({.type = "nope", .freq_hz = 10.0}).find("valid types: zv, mzv"), std::string::npos);
  EXPECT_NE(message({.type = "zv", .freq_hz = 10.0, .residual_at_hz = {-1.0}}).find("residual_at_hz must be"),
            std::string::npos);
  ShaperReportOptions o{.type = "zv", .freq_hz = 10.0};
  o.test_damping_ratio = -0.5;
  EXPECT_NE(message(o).find("test_damping_ratio must be"), std::string::npos);
}

}  // namespace
}  // namespace amctl::shaping
