#include "amctl/control/discretize.hpp"

#include <fmt/format.h>
#include <unsupported/Eigen/MatrixFunctions>

#include "amctl/core/error.hpp"

namespace amctl::control {

Discretization discretize_zoh(const StateSpace& sys, double period_s) {
  const PolynomialDiscretization p = discretize_polynomial(sys.A(), sys.B(), 1, period_s);
  return Discretization{period_s, p.Phi, p.Psi, Eigen::MatrixXd(), sys.C(), sys.D()};
}

Discretization discretize_foh(const StateSpace& sys, double period_s) {
  // u(s) = u_k + s (u_{k+1} - u_k) / T: derivative vector [u_k, (u_{k+1}-u_k)/T].
  const PolynomialDiscretization p = discretize_polynomial(sys.A(), sys.B(), 2, period_s);
  const auto m = sys.inputs();
  return Discretization{period_s, p.Phi, p.Psi.leftCols(m), p.Psi.middleCols(m, m) / period_s,
                        sys.C(), sys.D()};
}

PolynomialDiscretization discretize_polynomial(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B,
                                               int terms, double h) {
  require_positive("period_s (sampling period)", h);
  if (A.rows() != A.cols() || B.rows() != A.rows()) {
    throw Error(fmt::format("state-space sizes do not match: A is {}x{}, B is {}x{}", A.rows(),
                            A.cols(), B.rows(), B.cols()));
  }
  if (terms < 1) throw Error(fmt::format("terms must be >= 1, got {}", terms));
  const auto n = A.rows(), m = B.cols();
  const auto N = n + terms * m;
  // [x; w_0; ...; w_{d}]' = [[A, B, 0 ...], [0, 0, I, 0..], ..., [0 ... 0]] [x; w]
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(N, N);
  M.topLeftCorner(n, n) = A;
  M.block(0, n, n, m) = B;
  for (int j = 0; j + 1 < terms; ++j) {
    M.block(n + j * m, n + (j + 1) * m, m, m) = Eigen::MatrixXd::Identity(m, m);
  }
  const Eigen::MatrixXd E = (M * h).exp();
  PolynomialDiscretization out;
  out.period_s = h;
  out.terms = terms;
  out.Phi = E.topLeftCorner(n, n);
  out.Psi = E.topRightCorner(n, terms * m);
  return out;
}

}  // namespace amctl::control
