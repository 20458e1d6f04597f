// The exact inverse of the modal belt model (docs/compensation.md, section 1).
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "detail.hpp"

namespace amctl::compensation::detail {
namespace {

using Poly = std::vector<double>;  // ascending coefficients

Poly mul(const Poly& a, const Poly& b) {
  Poly c(a.size() + b.size() - 1, 0.0);
  for (std::size_t i = 0; i < a.size(); ++i)
    for (std::size_t j = 0; j < b.size(); ++j) c[i + j] += a[i] * b[j];
  return c;
}

Poly add(Poly a, const Poly& b, double s = 1.0) {
  if (b.size() > a.size()) a.resize(b.size(), 0.0);
  for (std::size_t i = 0; i < b.size(); ++i) a[i] += s * b[i];
  return a;
}

void trim(Poly& p) {
  double mx = 0.0;
  for (double c : p) mx = std::max(mx, std::abs(c));
  while (p.size() > 1 && std::abs(p.back()) <= 1e-12 * mx) p.pop_back();
}

constexpr int kInputTerms = plan::kMaxPieceDegree - 1;  // x'' and its derivatives 1..4

}  // namespace

InverseFilter::InverseFilter(const dynamics::AxisModel& model) {
  // In sigma = s / w_ref (w_ref the highest natural frequency) every coefficient is O(1):
  // D_i = sigma^2 + 2 z_i rho_i sigma + rho_i^2, rho_i = w_i / w_ref, and
  // H(s) = (1 / w_ref^2) P(sigma) / N(sigma).
  const double w_ref = 2.0 * M_PI * model.max_natural_frequency_hz();
  Poly D{1.0}, P{0.0};
  for (std::size_t i = 0; i < model.modes().size(); ++i) {
    const dynamics::Mode& m = model.modes()[i];
    const double rho = 2.0 * M_PI * m.natural_frequency_hz / w_ref;
    const Poly Di{rho * rho, 2.0 * m.damping_ratio * rho, 1.0};
    P = add(mul(P, Di), D, m.participation);  // P D_i + g_i prod_{j<i} D_j
    D = mul(D, Di);
  }
  Poly N = add(D, mul(Poly{0.0, 0.0, 1.0}, P), -1.0);
  trim(N);
  trim(P);
  const int n = static_cast<int>(N.size()) - 1;
  const int np = static_cast<int>(P.size()) - 1;
  relative_degree_ = n - np;
  if (relative_degree_ < 0)
    throw Error("--method invert: the inverse of this model is improper (participations summing "
                "to more than 1?)");
  const double lead = N.back();
  for (double& c : N) c /= lead;
  for (double& c : P) c /= lead;
  P.resize(static_cast<std::size_t>(n) + 1, 0.0);
  const double d_sigma = P[static_cast<std::size_t>(n)];
  const double w2 = w_ref * w_ref;
  d_ = d_sigma / w2;
  A_ = Eigen::MatrixXd::Zero(n, n);
  B_ = Eigen::VectorXd::Zero(n);
  C_ = Eigen::RowVectorXd::Zero(n);
  for (int i = 0; i + 1 < n; ++i) A_(i, i + 1) = 1.0;
  for (int i = 0; i < n; ++i) {
    A_(n - 1, i) = -N[static_cast<std::size_t>(i)];
    C_(i) = (P[static_cast<std::size_t>(i)] - d_sigma * N[static_cast<std::size_t>(i)]) / w2;
  }
  if (n > 0) {
    B_(n - 1) = 1.0;
    const Eigen::VectorXcd ev = Eigen::EigenSolver<Eigen::MatrixXd>(A_).eigenvalues();
    double max_re = -std::numeric_limits<double>::infinity();
    for (const auto& e : ev) max_re = std::max(max_re, e.real());
    if (!(max_re < -1e-9))
      throw Error(fmt::format(
          "--method invert: the model has zeros at or right of the imaginary axis (largest real "
          "part {:.3g} rad/s): its inverse is unstable; use --method fbf", max_re * w_ref));
    A_ *= w_ref;
    B_ *= w_ref;
    settle_s_ = 30.0 / (-max_re * w_ref);
  }
}

InverseRun run_inverse(std::span<const plan::PlannedMove> moves, const InverseFilter& fx,
                       const InverseFilter& fy, const Grid& grid, CompensationResult& r) {
  InverseRun run;
  const InverseFilter* f[2] = {&fx, &fy};
  Eigen::VectorXd z[2] = {Eigen::VectorXd::Zero(fx.states()), Eigen::VectorXd::Zero(fy.states())};
  control::PolynomialDiscretization full[2];
  for (int a = 0; a < 2; ++a)
    if (f[a]->states() > 0) full[a] = control::discretize_polynomial(f[a]->A(), f[a]->B(), kInputTerms, grid.h);

  r.t_s.resize(grid.count);
  r.x_cmd_mm.resize(grid.count);
  r.y_cmd_mm.resize(grid.count);
  r.x_des_mm.resize(grid.count);
  r.y_des_mm.resize(grid.count);
  r.lead_in_s = static_cast<double>(grid.lead_steps) * grid.h;
  r.tail_s = grid.t(grid.count - 1) - moves.back().end_time_s();

  trajectory::Cursor cur(moves);
  std::array<double, plan::kMaxPieceDegree + 1> d{}, dl{}, dr{};
  auto propagate = [&](int a, double tau, const std::array<double, plan::kMaxPieceDegree + 1>& dd,
                       double ra) {
    if (f[a]->states() == 0 || !(tau > 0.0)) return;
    Eigen::VectorXd u(kInputTerms);
    for (int j = 0; j < kInputTerms; ++j) u(j) = ra * dd[static_cast<std::size_t>(j + 2)];
    if (std::abs(tau - grid.h) <= 1e-12 * grid.h) {
      z[a] = full[a].Phi * z[a] + full[a].Psi * u;
    } else {
      const control::PolynomialDiscretization p =
          control::discretize_polynomial(f[a]->A(), f[a]->B(), kInputTerms, tau);
      z[a] = p.Phi * z[a] + p.Psi * u;
    }
  };
  auto tol = [](double v) { return 1e-7 * (1.0 + std::abs(v)); };

  for (std::size_t k = 0; k < grid.count; ++k) {
    const double t = grid.t(k);
    // The sample (right limit at t).
    const trajectory::Cursor::Location& loc = cur.locate(t);
    trajectory::Cursor::path_derivatives(loc, t, d);
    const plan::PlannedMove& mv = moves[loc.move_index];
    double acc[2];
    double* cmd[2] = {&r.x_cmd_mm[k], &r.y_cmd_mm[k]};
    double* des[2] = {&r.x_des_mm[k], &r.y_des_mm[k]};
    for (int a = 0; a < 2; ++a) {
      const double ra = mv.axes_r[a];
      const double x = mv.start_mm[a] + ra * d[0], x2 = ra * d[2], x3 = ra * d[3], x4 = ra * d[4];
      *des[a] = x;
      const InverseFilter& F = *f[a];
      double xb = x + F.d() * x2, xb2 = x2 + F.d() * x4;
      if (F.states() > 0) {
        xb += F.C() * z[a];
        const Eigen::VectorXd zd = F.A() * z[a] + F.B() * x2;
        xb2 += F.C() * (F.A() * zd) + (F.C() * F.B())(0) * x3;
      }
      *cmd[a] = xb;
      acc[a] = xb2;
    }
    r.t_s[k] = t;
    run.peak_accel_mm_s2 = std::max(run.peak_accel_mm_s2, std::hypot(acc[0], acc[1]));
    if (k + 1 == grid.count) break;

    // Advance to the next sample, split at piece boundaries.
    const double b = grid.t(k + 1);
    double s = t;
    while (s < b) {
      const trajectory::Cursor::Location l = cur.locate(s);
      const double e = std::min(b, l.piece_end_s);
      trajectory::Cursor::path_derivatives(l, s, d);
      const plan::PlannedMove& m = moves[l.move_index];
      for (int a = 0; a < 2; ++a) propagate(a, e - s, d, m.axes_r[a]);
      if (e >= b && l.piece_end_s > b) break;
      // A boundary at e: the jumps of x', x'', x''' across it.
      trajectory::Cursor::path_derivatives(l, e, dl);
      const trajectory::Cursor::Location l2 = cur.locate(e);
      trajectory::Cursor::path_derivatives(l2, e, dr);
      const plan::PlannedMove& m2 = moves[l2.move_index];
      for (int a = 0; a < 2; ++a) {
        const double ra = l.holding ? 0.0 : m.axes_r[a], rb = l2.holding ? 0.0 : m2.axes_r[a];
        const double dv = rb * dr[1] - ra * dl[1];
        const double da = rb * dr[2] - ra * dl[2];
        const double dj = rb * dr[3] - ra * dl[3];
        if (std::abs(dv) > tol(ra * dl[1])) {
          run.velocity_jump = true;
          if (f[a]->states() > 0) z[a] += f[a]->B() * dv;  // x'' holds dv * delta
        }
        if (std::abs(da) > tol(ra * dl[2])) run.accel_jump = true;
        if (std::abs(dj) > tol(ra * dl[3])) run.jerk_jump = true;
      }
      s = e;
      if (e >= b) break;
    }
  }
  // Smoothness of x_b = x + H x'': H adds relative_degree orders of smoothness to x''.
  const int rd = std::min(fx.relative_degree(), fy.relative_degree());
  run.unbounded_accel = run.velocity_jump || (run.accel_jump && rd < 2) || (run.jerk_jump && rd < 1);
  run.unbounded_jerk = run.unbounded_accel || (run.accel_jump && rd < 3) || (run.jerk_jump && rd < 2);
  return run;
}

}  // namespace amctl::compensation::detail
