#include "amctl/core/error.hpp"

#include <cmath>

#include <gtest/gtest.h>

namespace amctl {
namespace {

TEST(Error, MessageStartsWithFileLineColumn) {
  const Error e(SourceLocation{"part.gcode", 12, 7}, "expected a number after 'X'");
  EXPECT_STREQ(e.what(), "part.gcode:12:7: expected a number after 'X'");
  EXPECT_EQ(e.detail(), "expected a number after 'X'");
  EXPECT_EQ(e.where().line, 12u);
}

TEST(Error, LocationWithoutColumnOmitsIt) {
  EXPECT_EQ((SourceLocation{"a.toml", 3, 0}).to_string(), "a.toml:3");
  EXPECT_EQ((SourceLocation{"a.toml", 0, 0}).to_string(), "a.toml");
}

TEST(Error, RequirePositiveRejectsZeroNegativeAndNaN) {
  EXPECT_NO_THROW(require_positive("max_accel", 1.0));
  EXPECT_THROW(require_positive("max_accel", 0.0), Error);
  EXPECT_THROW(require_positive("max_accel", -3.0), Error);
  EXPECT_THROW(require_positive("max_accel", std::nan("")), Error);
  try {
    require_positive("max_accel", -3.0);
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_accel"), std::string::npos);
  }
}

TEST(Error, CheckThrowsInternalError) {
  EXPECT_THROW(AMCTL_CHECK(1 == 2, "arithmetic"), InternalError);
}

}  // namespace
}  // namespace amctl
