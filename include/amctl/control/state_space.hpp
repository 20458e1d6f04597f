#pragma once
// Continuous-time linear time-invariant systems in state-space form, and their transfer
// function / frequency response. Shared by dynamics (axis models), thermal (powder-bed loops)
// and every later controller module. See docs/control.md.
//
//     x'(t) = A x(t) + B u(t),     y(t) = C x(t) + D u(t),     t in seconds,
//     G(s)  = C (s I - A)^-1 B + D,     frequency response G(j w), w in rad/s.
//
// n states, m inputs, p outputs: A is n x n, B n x m, C p x n, D p x m. The units of x, u
// and y are the caller's (each model documents its own); A has units 1/s.
#include <complex>

#include <Eigen/Dense>

namespace amctl::control {

/// An immutable continuous LTI system. The constructor checks the shapes and that every
/// entry is finite, so a StateSpace that exists is always well formed.
class StateSpace {
 public:
  /// Throws amctl::Error naming the matrix for a non-square A, a B, C or D whose size does
  /// not match A (and each other), or a non-finite entry. n = 0 (a static gain D) is allowed.
  StateSpace(Eigen::MatrixXd a, Eigen::MatrixXd b, Eigen::MatrixXd c, Eigen::MatrixXd d);
  /// Single input, single output: B a column, C a row, D the scalar feedthrough.
  [[nodiscard]] static StateSpace siso(Eigen::MatrixXd a, const Eigen::VectorXd& b,
                                       const Eigen::RowVectorXd& c, double d = 0.0);

  [[nodiscard]] const Eigen::MatrixXd& A() const { return a_; }  ///< n x n, 1/s
  [[nodiscard]] const Eigen::MatrixXd& B() const { return b_; }  ///< n x m
  [[nodiscard]] const Eigen::MatrixXd& C() const { return c_; }  ///< p x n
  [[nodiscard]] const Eigen::MatrixXd& D() const { return d_; }  ///< p x m
  [[nodiscard]] Eigen::Index states() const { return a_.rows(); }
  [[nodiscard]] Eigen::Index inputs() const { return b_.cols(); }
  [[nodiscard]] Eigen::Index outputs() const { return c_.rows(); }
  [[nodiscard]] bool is_siso() const { return inputs() == 1 && outputs() == 1; }

 private:
  Eigen::MatrixXd a_, b_, c_, d_;
};

/// G(s) = C (s I - A)^-1 B + D at a complex frequency s [rad/s], p x m. Throws amctl::Error
/// if s is an eigenvalue of A (s I - A singular) or s is not finite.
[[nodiscard]] Eigen::MatrixXcd transfer_matrix(const StateSpace& sys, std::complex<double> s);

/// G(s) of a SISO system as a scalar. Throws amctl::Error unless the system has one input and
/// one output.
[[nodiscard]] std::complex<double> transfer_siso(const StateSpace& sys, std::complex<double> s);

/// Frequency response G(j w) at the angular frequency omega_rad_s (any real value), p x m.
[[nodiscard]] Eigen::MatrixXcd frequency_response(const StateSpace& sys, double omega_rad_s);

/// One point of a SISO Bode plot.
struct BodePoint {
  double omega_rad_s = 0.0;
  double magnitude = 0.0;     ///< |G(j w)| in the units of y per unit of u
  double magnitude_db = 0.0;  ///< 20 log10 |G(j w)|
  double phase_rad = 0.0;     ///< arg G(j w) in (-pi, pi]
};

/// |G|, 20 log10 |G| and arg G of a SISO system at omega_rad_s.
[[nodiscard]] BodePoint bode_point(const StateSpace& sys, double omega_rad_s);

}  // namespace amctl::control
