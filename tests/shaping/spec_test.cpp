// Shaper type names and parameters as Klipper's init_shaper reads them.
#include <string>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::shaping {
namespace {

std::string error_of(std::string_view text) {
  try {
    (void)parse_shaper_spec(text);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ShaperSpec, ReadsEveryNameWithoutRegardToCase) {
  EXPECT_EQ(parse_shaper_spec("ZV").type, ShaperType::zv);
  EXPECT_EQ(parse_shaper_spec(" mzv ").type, ShaperType::mzv);
  EXPECT_EQ(parse_shaper_spec("2HUMP_EI").type, ShaperType::two_hump_ei);
  EXPECT_EQ(parse_shaper_spec("3hump_ei").type, ShaperType::three_hump_ei);
  EXPECT_EQ(parse_shaper_spec("ZVDDD").type, ShaperType::zvddd);
  for (std::string_view name : shaper_type_names()) {
    EXPECT_EQ(to_string(parse_shaper_spec(name)), name);
  }
}

TEST(ShaperSpec, ReadsKlippersGeneralisedMzv) {
  const ShaperSpec d = parse_shaper_spec("mzv()");
  EXPECT_EQ(d.mzv_n, 3);
  EXPECT_EQ(d.mzv_t, 0.75);
  const ShaperSpec n4 = parse_shaper_spec("mzv(n=4)");
  EXPECT_EQ(n4.mzv_n, 4);
  EXPECT_EQ(n4.mzv_t, 0.75);
  const ShaperSpec pos = parse_shaper_spec("mzv(4, 1.2)");
  EXPECT_EQ(pos.mzv_n, 4);
  EXPECT_EQ(pos.mzv_t, 1.2);
  // tau: t = tau (n - 1) / (n + 2 tau - 2); tau wins over t as in Klipper.
  const ShaperSpec tau = parse_shaper_spec("MZV(n=6, t=0.9, tau=1.5)");
  EXPECT_DOUBLE_EQ(tau.mzv_t, 1.5 * 5.0 / (6.0 + 3.0 - 2.0));
  EXPECT_EQ(to_string(pos), "mzv(n=4, t=1.2)");
  EXPECT_EQ(to_string(parse_shaper_spec("mzv(n=3, t=0.75)")), "mzv");
  EXPECT_EQ(parse_shaper_spec(to_string(tau)).mzv_t, tau.mzv_t);
  EXPECT_EQ(parse_shaper_spec("ei(v_tol=0.1)").ei_v_tol, 0.1);
  EXPECT_EQ(parse_shaper_spec("ei(0.1)").ei_v_tol, 0.1);
  EXPECT_EQ(to_string(parse_shaper_spec("ei(v_tol=0.1)")), "ei(v_tol=0.1)");
}

TEST(ShaperSpec, RejectsWhatKlipperRejects) {
  EXPECT_NE(error_of("zvx").find("type 'zvx' is not a known shaper; valid types: zv, mzv, zvd, "
                                 "ei, 2hump_ei, 3hump_ei, zvdd, zvddd"),
            std::string::npos);
  EXPECT_NE(error_of("mzv(n=2)").find("n = 2 is too small, must be at least 3"), std::string::npos);
  EXPECT_NE(error_of("mzv(n=1000000)").find("n = 1000000 is too large, must be at most 64"),
            std::string::npos);
  EXPECT_EQ(error_of("mzv(n=64)"), "");
  EXPECT_NE(error_of("mzv(n=3, t=1.0)").find("t = 1.000000 is too large for n = 3, must be less than 1.000000"),
            std::string::npos);
  EXPECT_EQ(error_of("mzv(n=4, t=1)"), "");
  EXPECT_NE(error_of("mzv(4, t=1)").find("mixing named and positional"), std::string::npos);
  EXPECT_NE(error_of("mzv(n=4.0)").find("parameter n = '4.0' is not an integer"), std::string::npos);
  EXPECT_NE(error_of("mzv(m=4)").find("unknown mzv parameter 'm'"), std::string::npos);
  EXPECT_NE(error_of("mzv(n=4").find("expected ')'"), std::string::npos);
  EXPECT_NE(error_of("zv(3)").find("zv takes no parameters"), std::string::npos);
  EXPECT_NE(error_of("ei(v_tol=-1)").find("is not a finite number >= 0"), std::string::npos);
  EXPECT_NE(error_of("ei(x=0.1)").find("ei takes one parameter, v_tol"), std::string::npos);
}

}  // namespace
}  // namespace amctl::shaping
