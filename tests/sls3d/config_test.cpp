#include <gtest/gtest.h>

#include "amctl/sls3d/config.hpp"

namespace amctl::sls3d {
namespace {

TEST(Sls3dConfig, DefaultScheduleMatchesThePaperInstants) {
  ScenarioConfig c;
  c.validate();
  const auto s = layer_schedule(c);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_DOUBLE_EQ(s[0].spread_s, 0.0);
  EXPECT_DOUBLE_EQ(s[0].exposure_start_s, 14.0);
  EXPECT_NEAR(s[0].exposure_end_s, 15.0996, 1e-3);
  EXPECT_NEAR(s[1].spread_s, 15.1, 1e-12);
  EXPECT_NEAR(s[1].exposure_end_s, 28.0996, 1e-3);
}

}  // namespace
}  // namespace amctl::sls3d
