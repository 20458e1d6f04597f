#include "amctl/control/state_space.hpp"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::control {

using cd = std::complex<double>;

namespace {
void require_finite_matrix(const char* name, const Eigen::MatrixXd& m) {
  for (Eigen::Index j = 0; j < m.cols(); ++j)
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      if (!std::isfinite(m(i, j)))
        throw Error(fmt::format("state space: {}({}, {}) must be finite, got {}", name, i, j,
                                m(i, j)));
}

Eigen::MatrixXcd shifted_resolvent_lhs(const Eigen::MatrixXd& a, cd s) {
  if (!std::isfinite(s.real()) || !std::isfinite(s.imag()))
    throw Error(fmt::format("transfer function: s must be finite, got {}{:+}j", s.real(),
                            s.imag()));
  Eigen::MatrixXcd m = -a.cast<cd>();
  m.diagonal().array() += s;
  return m;
}

void require_regular(const Eigen::PartialPivLU<Eigen::MatrixXcd>& lu, cd s) {
  // Partial pivoting keeps going on a singular matrix; a zero pivot says s is a pole.
  const auto& u = lu.matrixLU();
  for (Eigen::Index i = 0; i < u.rows(); ++i)
    if (u(i, i) == cd(0.0, 0.0))
      throw Error(fmt::format("transfer function: s = {}{:+}j is a pole (an eigenvalue of A)",
                              s.real(), s.imag()));
}
}  // namespace

StateSpace::StateSpace(Eigen::MatrixXd a, Eigen::MatrixXd b, Eigen::MatrixXd c,
                       Eigen::MatrixXd d)
    : a_(std::move(a)), b_(std::move(b)), c_(std::move(c)), d_(std::move(d)) {
  if (a_.rows() != a_.cols())
    throw Error(fmt::format("state space: A must be square (n x n), got {}x{}", a_.rows(),
                            a_.cols()));
  const Eigen::Index n = a_.rows();
  if (b_.rows() != n)
    throw Error(fmt::format("state space: B must have one row per state ({}), got {}x{}", n,
                            b_.rows(), b_.cols()));
  if (c_.cols() != n)
    throw Error(fmt::format("state space: C must have one column per state ({}), got {}x{}",
                            n, c_.rows(), c_.cols()));
  if (d_.rows() != c_.rows() || d_.cols() != b_.cols())
    throw Error(fmt::format("state space: D must be outputs x inputs = {}x{}, got {}x{}",
                            c_.rows(), b_.cols(), d_.rows(), d_.cols()));
  require_finite_matrix("A", a_);
  require_finite_matrix("B", b_);
  require_finite_matrix("C", c_);
  require_finite_matrix("D", d_);
}

StateSpace StateSpace::siso(Eigen::MatrixXd a, const Eigen::VectorXd& b,
                            const Eigen::RowVectorXd& c, double d) {
  return StateSpace(std::move(a), Eigen::MatrixXd(b), Eigen::MatrixXd(c),
                    Eigen::MatrixXd::Constant(1, 1, d));
}

Eigen::MatrixXcd transfer_matrix(const StateSpace& sys, cd s) {
  const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(shifted_resolvent_lhs(sys.A(), s));
  if (sys.states() > 0) require_regular(lu, s);
  Eigen::MatrixXcd g = sys.D().cast<cd>();
  if (sys.states() > 0) g += sys.C().cast<cd>() * lu.solve(sys.B().cast<cd>());
  return g;
}

cd transfer_siso(const StateSpace& sys, cd s) {
  if (!sys.is_siso())
    throw Error(fmt::format("transfer_siso needs one input and one output, the system has {} "
                            "inputs and {} outputs",
                            sys.inputs(), sys.outputs()));
  if (sys.states() == 0) return cd(sys.D()(0, 0), 0.0);
  // Vector operands (not 1-column matrices): the same operations, in the same order, as the
  // powder-bed margin code always used, so its printed figures do not move.
  const Eigen::VectorXd b = sys.B().col(0);
  const Eigen::RowVectorXd c = sys.C().row(0);
  const Eigen::PartialPivLU<Eigen::MatrixXcd> lu(shifted_resolvent_lhs(sys.A(), s));
  require_regular(lu, s);
  const Eigen::VectorXcd x = lu.solve(b.cast<cd>());
  return (c.cast<cd>() * x)(0) + sys.D()(0, 0);
}

Eigen::MatrixXcd frequency_response(const StateSpace& sys, double omega_rad_s) {
  return transfer_matrix(sys, cd(0.0, omega_rad_s));
}

BodePoint bode_point(const StateSpace& sys, double omega_rad_s) {
  const cd g = transfer_siso(sys, cd(0.0, omega_rad_s));
  BodePoint p;
  p.omega_rad_s = omega_rad_s;
  p.magnitude = std::abs(g);
  p.magnitude_db = 20.0 * std::log10(p.magnitude);
  p.phase_rad = std::arg(g);
  return p;
}

}  // namespace amctl::control
