#pragma once
// Exact propagation of one mode block (2 states) over a duration tau with a polynomial input
// u(s) = sum_j u_j s^j / j!,  j < kMaxInputTerms:
//     x(tau) = Phi x(0) + sum_j psi_j u_j,
//     Phi = phi_0(Z), psi_j = tau^{j+1} phi_{j+1}(Z) B,  Z = A tau,
// phi_k(Z) = sum_m Z^m / (m + k)! (so phi_k = Z phi_{k+1} + I / k!). For ||Z||_1 <= 2 the
// highest phi is summed as a series and the others follow from that downward recursion;
// otherwise Eigen's matrix exponential of the augmented matrix is used.
#include <array>

#include "amctl/dynamics/model.hpp"

namespace amctl::dynamics {

/// Derivative terms of the input: u = x_b'' of a degree-6 path polynomial has 5.
inline constexpr int kMaxInputTerms = 5;

struct ModePropagator {
  double phi[2][2]{};                    ///< state transition
  double psi[2][kMaxInputTerms]{};       ///< input response, column j for u^(j)(0)
  /// Particular response to the polynomial input: x_p = sum_j pi_j u_j (A x_p + B u = x_p').
  double pi[2][kMaxInputTerms]{};
};

/// Throws amctl::Error for tau < 0 or terms outside [1, kMaxInputTerms].
[[nodiscard]] ModePropagator mode_propagator(const Mode& mode, double tau_s, int terms);

}  // namespace amctl::dynamics
