#include "amctl/dynamics/propagator.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/control/discretize.hpp"

namespace amctl::dynamics {

namespace {
struct M2 {
  double a = 0, b = 0, c = 0, d = 0;  // [[a, b], [c, d]]
};
inline M2 mul(const M2& x, const M2& y) {
  return {x.a * y.a + x.b * y.c, x.a * y.b + x.b * y.d, x.c * y.a + x.d * y.c,
          x.c * y.b + x.d * y.d};
}
}  // namespace

ModePropagator mode_propagator(const Mode& mode, double tau, int terms) {
  if (!(tau >= 0.0) || !std::isfinite(tau)) {
    throw Error(fmt::format("propagation duration tau_s must be >= 0, got {}", tau));
  }
  if (terms < 1 || terms > kMaxInputTerms) {
    throw Error(fmt::format("input terms must be in [1, {}], got {}", kMaxInputTerms, terms));
  }
  const double w = 2.0 * std::numbers::pi * mode.natural_frequency_hz;
  const double z = mode.damping_ratio;
  const double bq = -mode.participation / w;  // B = [0, bq]
  ModePropagator out;
  // Particular solution: pi_0 = -A^{-1} B, pi_j = A^{-1} pi_{j-1};
  // A^{-1} = (1/w^2) [[-2 z w, -w], [w, 0]].
  {
    const double iw2 = 1.0 / (w * w);
    double p0 = bq / w, p1 = 0.0;  // -A^{-1} B
    for (int j = 0; j < kMaxInputTerms; ++j) {
      out.pi[0][j] = p0;
      out.pi[1][j] = p1;
      const double n0 = iw2 * (-2.0 * z * w * p0 - w * p1);
      const double n1 = iw2 * (w * p0);
      p0 = n0;
      p1 = n1;
    }
  }
  const M2 Z{0.0, w * tau, -w * tau, -2.0 * z * w * tau};
  const double norm1 = std::max(std::abs(Z.c), std::abs(Z.b) + std::abs(Z.d));
  if (norm1 <= 2.0) {
    // Series for phi_K, K = terms, then phi_k = Z phi_{k+1} + I/k! downwards.
    // Truncate where the next term norm1^M / (M + K)! falls below 1e-18 of the first.
    constexpr int kMaxSeries = 30;
    const int K = terms;
    double fact[kMaxSeries + kMaxInputTerms + 2];
    fact[0] = 1.0;
    for (int i = 1; i < kMaxSeries + kMaxInputTerms + 2; ++i) fact[i] = fact[i - 1] * i;
    // Terms m of phi_K relative to its first: norm1^m K! / (m + K)!; stop below 1e-17.
    int kSeries = 1;
    for (double rel = norm1 / (K + 1); kSeries < kMaxSeries && rel > 1e-17; ++kSeries) {
      rel *= norm1 / (kSeries + K + 1);
    }
    M2 P{1.0 / fact[kSeries + K], 0.0, 0.0, 1.0 / fact[kSeries + K]};
    for (int m = kSeries - 1; m >= 0; --m) {
      P = mul(Z, P);
      P.a += 1.0 / fact[m + K];
      P.d += 1.0 / fact[m + K];
    }
    // P = phi_K. psi_j = tau^{j+1} phi_{j+1} B, and B has only its second entry.
    double tpow[kMaxInputTerms + 1];
    tpow[0] = 1.0;
    for (int k = 1; k <= K; ++k) tpow[k] = tpow[k - 1] * tau;
    for (int k = K; k >= 1; --k) {
      out.psi[0][k - 1] = tpow[k] * P.b * bq;
      out.psi[1][k - 1] = tpow[k] * P.d * bq;
      P = mul(Z, P);
      P.a += 1.0 / fact[k - 1];
      P.d += 1.0 / fact[k - 1];
    }
    out.phi[0][0] = P.a;
    out.phi[0][1] = P.b;
    out.phi[1][0] = P.c;
    out.phi[1][1] = P.d;
    return out;
  }
  Eigen::MatrixXd A(2, 2), B(2, 1);
  A << 0.0, w, -w, -2.0 * z * w;
  B << 0.0, bq;
  const control::PolynomialDiscretization p = control::discretize_polynomial(A, B, terms, tau);
  for (int r = 0; r < 2; ++r) {
    for (int c = 0; c < 2; ++c) out.phi[r][c] = p.Phi(r, c);
    for (int j = 0; j < terms; ++j) out.psi[r][j] = p.Psi(r, j);
  }
  return out;
}

}  // namespace amctl::dynamics
