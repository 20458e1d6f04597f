#include "amctl/dynamics/propagator.hpp"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "amctl/control/discretize.hpp"

namespace amctl::dynamics {
namespace {

TEST(ModePropagator, SeriesBranchAgreesWithAugmentedMatrixExponential) {
  for (const Mode mode : {Mode{15.9, 0.5, 1.0}, Mode{80.0, 0.0, 0.6}, Mode{35.0, 2.0, 1.0}}) {
    const AxisModel m = AxisModel::from_modes({mode});
    for (double tau : {1e-7, 1e-4, 0.0013, 0.004, 0.02}) {
      for (int terms = 1; terms <= kMaxInputTerms; ++terms) {
        const ModePropagator p = mode_propagator(mode, tau, terms);
        const control::PolynomialDiscretization ref =
            control::discretize_polynomial(m.A(), m.B(), terms, tau);
        for (int r = 0; r < 2; ++r) {
          for (int c = 0; c < 2; ++c) EXPECT_NEAR(p.phi[r][c], ref.Phi(r, c), 1e-13);
          for (int j = 0; j < terms; ++j) {
            EXPECT_NEAR(p.psi[r][j], ref.Psi(r, j), 1e-13 * (std::abs(ref.Psi(r, j)) + 1e-12))
                << "tau " << tau << " terms " << terms << " j " << j;
          }
        }
      }
    }
  }
}

TEST(ModePropagator, ParticularSolutionOfConstantAccelerationIsStaticDeflection) {
  // e'' + 2 z w e' + w^2 e = -a  ->  e_ss = -a / w^2, e'_ss = 0.
  const Mode mode{20.0, 0.1, 1.0};
  const double w = 2 * std::numbers::pi * 20.0;
  const ModePropagator p = mode_propagator(mode, 0.001, 1);
  EXPECT_NEAR(p.pi[0][0], -1.0 / (w * w), 1e-18);
  EXPECT_NEAR(p.pi[1][0], 0.0, 1e-18);
  // ramp a = j t: e_ss = -(j/w^2)(t - 2 z / w): the u' coefficient is 2 z / w^3
  EXPECT_NEAR(p.pi[0][1], 2 * 0.1 / (w * w * w), 1e-18);
}

}  // namespace
}  // namespace amctl::dynamics
