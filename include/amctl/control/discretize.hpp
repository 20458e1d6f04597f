#pragma once
// Exact discretisation of x' = A x + B u through the matrix exponential (docs/control.md).
//  ZOH (u held over the period T):      x+ = Phi x + Gamma0 u_k
//  FOH (u linear between samples):      x+ = Phi x + Gamma0 u_k + Gamma1 (u_{k+1} - u_k)
//  Polynomial input of degree d inside the period, u(s) = sum_j u^(j)(0) s^j / j!:
//                                       x+ = Phi x + sum_j Psi_j u^(j)(0)
//  with Phi = e^{A T}, Psi_j = int_0^T e^{A(T-s)} B s^j/j! ds = T^{j+1} phi_{j+1}(A T) B, all
//  read off exp([[A, B, 0..], [0, N]] T), N the nilpotent shift of the derivative vector
//  (Van Loan 1978). ZOH is the d = 0 case: exp([[A, B], [0, 0]] T) = [[Phi, Gamma0], [0, I]].
#include <Eigen/Dense>

#include "amctl/control/state_space.hpp"

namespace amctl::control {

/// A sampled system: x_{k+1} = Phi x_k + Gamma0 u_k [+ Gamma1 (u_{k+1} - u_k)],
/// y_k = C x_k + D u_k, sampled every period_s seconds.
struct Discretization {
  double period_s = 0.0;
  Eigen::MatrixXd Phi;     ///< n x n, e^{A T}
  Eigen::MatrixXd Gamma0;  ///< n x m
  Eigen::MatrixXd Gamma1;  ///< n x m (FOH only; empty for ZOH)
  Eigen::MatrixXd C;       ///< p x n, unchanged by sampling
  Eigen::MatrixXd D;       ///< p x m, unchanged by sampling
};

/// Zero-order hold. Throws amctl::Error unless period_s is finite and > 0.
[[nodiscard]] Discretization discretize_zoh(const StateSpace& sys, double period_s);
/// First-order hold (input linear between samples). Throws like discretize_zoh.
[[nodiscard]] Discretization discretize_foh(const StateSpace& sys, double period_s);

/// Phi(T) and Psi(T) (n x terms*m, block j = Psi_j) for inputs whose first `terms`
/// derivatives are given at the start of the period (terms = polynomial degree + 1).
struct PolynomialDiscretization {
  double period_s = 0.0;
  int terms = 0;
  Eigen::MatrixXd Phi;
  Eigen::MatrixXd Psi;
};
/// Throws amctl::Error for period_s not finite and > 0, terms < 1, a non-square A, or B
/// with a row count other than A's.
[[nodiscard]] PolynomialDiscretization discretize_polynomial(const Eigen::MatrixXd& A,
                                                             const Eigen::MatrixXd& B,
                                                             int terms, double period_s);

}  // namespace amctl::control
