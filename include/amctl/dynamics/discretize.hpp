#pragma once
// Exact discretisation of x' = A x + B u through the matrix exponential.
//  ZOH (u held over the step):          x+ = Phi x + Gamma0 u_k
//  FOH (u linear between samples):      x+ = Phi x + Gamma0 u_k + Gamma1 (u_{k+1} - u_k)
//  Polynomial input of degree d inside the step, u(s) = sum_j u^(j)(0) s^j / j!:
//                                       x+ = Phi x + sum_j Psi_j u^(j)(0)
//  with Psi_j = int_0^h e^{A(h-s)} B s^j/j! ds = h^{j+1} phi_{j+1}(A h) B, obtained as the
//  top-right block of exp([[A, B, 0..], [0, N]] h), N the nilpotent shift of the
//  derivative vector (Van Loan 1978). ZOH is the d = 0 case.
#include <Eigen/Dense>

#include "amctl/dynamics/model.hpp"

namespace amctl::dynamics {

struct Discretization {
  double step_s = 0.0;
  Eigen::MatrixXd Phi;     ///< n x n
  Eigen::MatrixXd Gamma0;  ///< n x m
  Eigen::MatrixXd Gamma1;  ///< n x m (FOH only; empty for ZOH)
};

/// Throws amctl::Error for step_s <= 0 or mismatched matrix sizes.
[[nodiscard]] Discretization discretize_zoh(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                            double step_s);
[[nodiscard]] Discretization discretize_foh(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                            double step_s);

/// Phi(h) and Psi(h) (n x terms*m, block j = Psi_j) for inputs whose first `terms`
/// derivatives are given at the start of the step (terms = polynomial degree + 1).
struct PolynomialDiscretization {
  double step_s = 0.0;
  int terms = 0;
  Eigen::MatrixXd Phi;
  Eigen::MatrixXd Psi;
};
[[nodiscard]] PolynomialDiscretization discretize_polynomial(const Eigen::MatrixXd& A,
                                                             const Eigen::MatrixXd& B,
                                                             int terms, double step_s);

}  // namespace amctl::dynamics
