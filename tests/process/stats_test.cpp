// Reference values: tests/reference/process_shrink_reference.py (scipy 1.10).
#include <gtest/gtest.h>

#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/process/stats.hpp"

namespace pr = amctl::process;

TEST(Stats, IncompleteBetaMatchesScipy) {
  EXPECT_NEAR(pr::incomplete_beta(2.5, 0.5, 0.3), 0.0189271240719457, 1e-13);
  EXPECT_DOUBLE_EQ(pr::incomplete_beta(2.0, 3.0, 0.0), 0.0);
  // I_x(1, 1) = x in closed form.
  EXPECT_NEAR(pr::incomplete_beta(1.0, 1.0, 0.37), 0.37, 1e-14);
}

TEST(Stats, StudentQuantilesMatchScipy) {
  EXPECT_NEAR(pr::student_t_quantile(0.975, 18), 2.10092204024096, 1e-10);
  EXPECT_NEAR(pr::student_t_quantile(0.975, 3), 3.18244630528426, 1e-10);
  EXPECT_NEAR(pr::student_t_quantile(0.9, 7.5), 1.40521184641511, 1e-10);
  EXPECT_NEAR(pr::student_t_quantile(0.999, 1), 318.308838985542, 1e-7);
  EXPECT_NEAR(pr::student_t_quantile(0.025, 18), -2.10092204024096, 1e-10);
}

TEST(Stats, LineThroughExactPointsHasZeroResidual) {
  const std::vector<double> x{0, 1, 2, 3};
  const std::vector<double> y{1, 3, 5, 7};
  const auto f = pr::fit_line(x, y);
  EXPECT_NEAR(f.slope, 2.0, 1e-14);
  EXPECT_NEAR(f.intercept, 1.0, 1e-14);
  EXPECT_NEAR(f.sse, 0.0, 1e-24);
  EXPECT_NEAR(f.r2, 1.0, 1e-14);
}

TEST(Stats, LineFitRejectsTooFewPointsAndSingularData) {
  const std::vector<double> two{1, 2};
  EXPECT_THROW((void)pr::fit_line(two, two), amctl::Error);
  const std::vector<double> same{5, 5, 5, 5};
  const std::vector<double> y{1, 2, 3, 4};
  try {
    (void)pr::fit_line(same, y, "test fit");
    FAIL() << "expected amctl::Error";
  } catch (const amctl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}
