// Filtered basis functions (Ramani, Duan, Okwudire 2017; docs/compensation.md, section 2).
//
// Command of one axis on the grid t_0 .. t_end = t_0 + M T (T = q h, q whole steps):
//     x_b(t) = x_0 + sum_{j < J} c_j N_j(t) + (x_end - x_0) S(t),   J = M - p,
// N_j(t) = B_p((t - t_0)/T - j) the uniform B-spline of degree p starting at knot j, and
// S = sum_{j >= J} N_j, which is 0 before knot J and 1 from t_end on (partition of unity):
// the command is at rest at x_0 up to t_0 and at rest at x_end from t_end on.
// The model is linear and time invariant, so the filtered basis functions are shifts of one
// response R_0 = L[N_0] by whole knots, computed once, exactly (the B-spline is a polynomial
// between knots and knots fall on samples). The weights minimise the sum over the grid of the
// squared tracking error: a banded least-squares problem (column j of the design matrix is
// nonzero on the rows of R_0's support shifted by j q), solved by a banded Cholesky factorisation of the normal equations.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/control/discretize.hpp"
#include "amctl/core/error.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "detail.hpp"

namespace amctl::compensation::detail {

std::vector<std::vector<double>> cardinal_bspline_pieces(int degree) {
  // pieces[i] = ascending coefficients in u of B_p(i + u), 0 <= u < 1, i = 0..p.
  std::vector<std::vector<double>> prev{{1.0}};
  for (int p = 1; p <= degree; ++p) {
    std::vector<std::vector<double>> cur(static_cast<std::size_t>(p) + 1,
                                         std::vector<double>(static_cast<std::size_t>(p) + 1, 0.0));
    for (int i = 0; i <= p; ++i) {
      auto& c = cur[static_cast<std::size_t>(i)];
      // (i + u)/p * B_{p-1}[i](u)
      if (i < p) {
        const auto& b = prev[static_cast<std::size_t>(i)];
        for (std::size_t k = 0; k < b.size(); ++k) {
          c[k] += i * b[k] / p;
          c[k + 1] += b[k] / p;
        }
      }
      // (p + 1 - i - u)/p * B_{p-1}[i-1](u)
      if (i > 0) {
        const auto& b = prev[static_cast<std::size_t>(i - 1)];
        for (std::size_t k = 0; k < b.size(); ++k) {
          c[k] += (p + 1 - i) * b[k] / p;
          c[k + 1] -= b[k] / p;
        }
      }
    }
    prev = std::move(cur);
  }
  return prev;
}

namespace {

/// k-th derivative of sum_m c_m u^m at u.
double poly_derivative(const std::vector<double>& c, int k, double u) {
  double v = 0.0;
  for (int m = static_cast<int>(c.size()) - 1; m >= k; --m) {
    double f = 1.0;
    for (int i = 0; i < k; ++i) f *= m - i;
    v = v * u + f * c[static_cast<std::size_t>(m)];
  }
  return v;
}

}  // namespace

Basis make_basis(int p, int q, double h) {
  Basis b;
  b.p = p;
  b.q = q;
  b.h = h;
  b.T = q * h;
  const auto pieces = cardinal_bspline_pieces(p);
  const int n = (p + 1) * q;
  b.val.assign(static_cast<std::size_t>(n) + 1, 0.0);
  b.acc.assign(static_cast<std::size_t>(n) + 1, 0.0);
  for (int m = 0; m < n; ++m) {
    const int i = m / q;
    const double u = static_cast<double>(m % q) / q;
    const auto& c = pieces[static_cast<std::size_t>(i)];
    b.val[static_cast<std::size_t>(m)] = poly_derivative(c, 0, u);
    b.acc[static_cast<std::size_t>(m)] = p >= 2 ? poly_derivative(c, 2, u) / (b.T * b.T) : 0.0;
  }
  return b;
}

/// R_0 = L[N_0] - N_0's own value is included: the nozzle's response at samples m = 0..,
/// exact (the input x_b'' is a polynomial between knots, knots on samples), truncated once the
/// vibration after the spline's support has decayed below 1e-10 of the peak.
std::vector<double> filtered_response(const dynamics::AxisModel& model, const Basis& b) {
  const int p = b.p, q = b.q;
  const auto pieces = cardinal_bspline_pieces(p);
  const Eigen::MatrixXd A = model.A();
  const Eigen::VectorXd B = model.B();
  const Eigen::RowVectorXd C = model.C();
  const int terms = std::max(1, p - 1);  // x_b'' has degree p - 2
  const control::PolynomialDiscretization d = control::discretize_polynomial(A, B, terms, b.h);
  Eigen::VectorXd e = Eigen::VectorXd::Zero(A.rows());
  const int support = (p + 1) * q;
  const double decay = slowest_decay_rate_per_s(model);
  const int max_len = support + static_cast<int>(std::ceil(std::min(40.0 / decay, 20.0) / b.h));
  std::vector<double> R;
  R.reserve(static_cast<std::size_t>(max_len));
  double peak = 0.0;
  Eigen::VectorXd u(terms);
  if (p == 1) e += B * (1.0 / b.T);  // the hat's first velocity step, at its start
  for (int m = 0; m < max_len; ++m) {
    const double y = (m < support ? b.val[static_cast<std::size_t>(m)] : 0.0) + C * e;
    R.push_back(y);
    peak = std::max(peak, std::abs(y));
    if (m >= support && e.norm() < 1e-10 * peak) break;
    // Advance one step: input derivatives at the step start.
    u.setZero();
    if (m < support && p >= 2) {
      const int i = m / q;
      const double uu = static_cast<double>(m % q) / q;
      const auto& c = pieces[static_cast<std::size_t>(i)];
      for (int j = 0; j < terms; ++j)
        u(j) = poly_derivative(c, j + 2, uu) / std::pow(b.T, j + 2);
    }
    e = d.Phi * e + d.Psi * u;
    // Degree 1: x_b' steps at the knots (x_b'' holds dv * delta): e jumps by B dv.
    if (p == 1 && (m + 1 == q || m + 1 == 2 * q)) e += B * ((m + 1 == q ? -2.0 : 1.0) / b.T);
  }
  return R;
}

FbfLayout fbf_layout_start(const plan::PlannedMove& first, const CompensationOptions& o) {
  FbfLayout lay;
  Grid& grid = lay.grid;
  const double h = 1.0 / o.sample_rate_hz;
  double f_max = std::max(o.model_x.max_natural_frequency_hz(), o.model_y.max_natural_frequency_hz());
  double decay = std::min(slowest_decay_rate_per_s(o.model_x), slowest_decay_rate_per_s(o.model_y));
  const double t_req = o.knot_spacing_s > 0.0 ? o.knot_spacing_s : 1.0 / (8.0 * f_max);
  if (o.knot_spacing_s > 0.0 && o.knot_spacing_s > 0.5 / f_max)
    throw Error(fmt::format(
        "--knot-spacing-s {} is too coarse for the model: the basis cannot follow its {} Hz mode; "
        "use at most half its period, {:.6g} s", o.knot_spacing_s, f_max, 0.5 / f_max));
  if (o.knot_spacing_s == 0.0 || (o.knot_spacing_s > 0.0 && o.knot_spacing_s < 0.5 * h))
    throw Error(fmt::format("--knot-spacing-s: must be at least one sample step ({1} s), got {0}",
                            o.knot_spacing_s, h));
  const int q = std::max(1, static_cast<int>(std::llround(t_req / h)));
  const double T = q * h;
  lay.settle_s = std::isfinite(decay) && decay > 0 ? 4.0 / decay : 0.0;
  const double lead = o.lead_in_s >= 0.0 ? o.lead_in_s
                                         : std::min(1.0, std::isfinite(decay) && decay > 0 ? 4.0 / decay : 1.0);
  const int lead_knots = static_cast<int>(std::ceil(lead / T - 1e-9));
  grid.h = h;
  grid.lead_steps = static_cast<std::size_t>(lead_knots) * static_cast<std::size_t>(q);
  grid.t0 = first.start_time_s - static_cast<double>(grid.lead_steps) * h;
  lay.q = q;
  return lay;
}

FbfLayout fbf_layout(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
                     double auto_tail_s) {
  FbfLayout lay = fbf_layout_start(moves.front(), o);
  const Grid& grid = lay.grid;
  const int p = o.degree, q = lay.q;
  const double T = q * grid.h;
  const double t_end_motion = moves.back().end_time_s();
  const double tail = o.tail_s >= 0.0 ? o.tail_s : auto_tail_s;
  const int M = static_cast<int>(std::ceil((t_end_motion + tail - grid.t0) / T - 1e-9));
  lay.grid.count = static_cast<std::size_t>(M) * static_cast<std::size_t>(q) + 1;
  const int J = M - p;
  if (J < p + 1)
    throw Error(fmt::format(
        "--knot-spacing-s {}: the basis ({} free B-splines of degree {}) does not cover the "
        "trajectory ({:.4g} s with lead-in and tail); use a finer knot spacing",
        T, std::max(J, 0), p, M * T));
  lay.M = M;
  return lay;
}

void sample_desired(std::span<const plan::PlannedMove> moves, const Grid& grid, CompensationResult& r) {
  const std::size_t K = grid.count;
  r.t_s.resize(K);
  r.x_des_mm.resize(K);
  r.y_des_mm.resize(K);
  trajectory::Cursor cur(moves);
  for (std::size_t k = 0; k < K; ++k) {
    r.t_s[k] = grid.t(k);
    const trajectory::AxisState s = cur.evaluate(r.t_s[k]);
    r.x_des_mm[k] = s.pos_mm[0];
    r.y_des_mm[k] = s.pos_mm[1];
  }
}

void run_fbf(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
             double auto_tail_s, Grid& grid, CompensationResult& r) {
  const FbfLayout lay = fbf_layout(moves, o, auto_tail_s);
  grid = lay.grid;
  const double h = grid.h;
  const int p = o.degree, q = lay.q, M = lay.M, J = M - p;
  const double T = q * h;
  const double t_end_motion = moves.back().end_time_s();
  r.knot_spacing_s = T;
  r.degree = p;
  r.basis_functions = static_cast<std::size_t>(J);
  r.lead_in_s = static_cast<double>(grid.lead_steps) * h;
  r.tail_s = grid.t(grid.count - 1) - t_end_motion;
  const std::size_t K = grid.count;
  sample_desired(moves, grid, r);

  const Basis basis = make_basis(p, q, h);
  std::vector<double>* cmd[2] = {&r.x_cmd_mm, &r.y_cmd_mm};
  const std::vector<double>* des[2] = {&r.x_des_mm, &r.y_des_mm};
  const dynamics::AxisModel* model[2] = {&o.model_x, &o.model_y};
  std::vector<double> acc[2];
  const auto column_row = [&](int j, std::size_t m) { return static_cast<std::size_t>(j) * q + m; };
  for (int a = 0; a < 2; ++a) {
    const std::vector<double> R = filtered_response(*model[a], basis);
    const double x0 = (*des[a]).front(), x1 = (*des[a]).back();
    // Right-hand side: desired minus the fixed part (x_0 and the end spline S).
    Eigen::VectorXd rhs(static_cast<Eigen::Index>(K));
    for (std::size_t k = 0; k < K; ++k) rhs(static_cast<Eigen::Index>(k)) = (*des[a])[k] - x0;
    for (int j = J; j < M; ++j)
      for (std::size_t m = 0; m < R.size() && column_row(j, m) < K; ++m)
        rhs(static_cast<Eigen::Index>(column_row(j, m))) -= (x1 - x0) * R[m];
    // Normal equations G c = Phi^T rhs. Column j of Phi is R shifted by j q rows (cut at the
    // grid's end), so G_ij (j = i + l) = sum_{m < n_j} R[m] R[m + l q] with
    // n_j = min(len - l q, K - j q): a prefix sum of one autocorrelation per lag. G is banded
    // (l q < len) and Toeplitz except for the last columns.
    const std::size_t len = R.size();
    const int L = static_cast<int>((len - 1) / static_cast<std::size_t>(q));
    std::vector<std::vector<double>> prefix(static_cast<std::size_t>(L) + 1);
    for (int l = 0; l <= L; ++l) {
      const std::size_t shift = static_cast<std::size_t>(l) * static_cast<std::size_t>(q);
      auto& pf = prefix[static_cast<std::size_t>(l)];
      pf.assign(len - shift + 1, 0.0);
      for (std::size_t m = 0; m + shift < len; ++m) pf[m + 1] = pf[m] + R[m] * R[m + shift];
    }
    // Lower band of G, row-wise: band[j (L+1) + (i - j + L)] = G(j, i), j - L <= i <= j.
    const std::size_t W = static_cast<std::size_t>(L) + 1;
    std::vector<double> band(static_cast<std::size_t>(J) * W, 0.0);
    double tr = 0.0;
    for (int j = 0; j < J; ++j) {
      const std::size_t rows_left = K - column_row(j, 0);
      for (int l = 0; l <= L && l <= j; ++l) {
        const auto& pf = prefix[static_cast<std::size_t>(l)];
        band[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(L - l)] =
            pf[std::min(pf.size() - 1, rows_left)];
      }
      tr += band[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(L)];
    }
    for (int j = 0; j < J; ++j)
      band[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(L)] += 1e-13 * tr / J;  // round-off floor
    const BandedCholesky chol(std::move(band), J, L);
    std::vector<double> c(static_cast<std::size_t>(J), 0.0);
    for (int j = 0; j < J; ++j)
      for (std::size_t m = 0; m < len && column_row(j, m) < K; ++m)
        c[static_cast<std::size_t>(j)] += R[m] * rhs(static_cast<Eigen::Index>(column_row(j, m)));
    chol.solve(c);
    assemble_axis(basis, q, J, M, K, c, x0, x1, *cmd[a], acc[a]);
  }
  set_fbf_status(r, acc[0], acc[1], p);
}

void assemble_axis(const Basis& basis, int q, int J, int M, std::size_t K, const std::vector<double>& c,
                   double x0, double x1, std::vector<double>& xb, std::vector<double>& acc) {
  const auto row = [q](int j, std::size_t m) { return static_cast<std::size_t>(j) * static_cast<std::size_t>(q) + m; };
  xb.assign(K, x0);
  acc.assign(K, 0.0);
  for (int j = 0; j < M; ++j) {
    const double w = j < J ? c[static_cast<std::size_t>(j)] : x1 - x0;
    for (std::size_t m = 0; m < basis.val.size() && row(j, m) < K; ++m) {
      xb[row(j, m)] += w * basis.val[m];
      acc[row(j, m)] += w * basis.acc[m];
    }
  }
}

void set_fbf_status(CompensationResult& r, const std::vector<double>& acc_x,
                    const std::vector<double>& acc_y, int degree) {
  r.peak_command_accel_mm_s2 = 0.0;
  for (std::size_t k = 0; k < acc_x.size(); ++k)
    r.peak_command_accel_mm_s2 = std::max(r.peak_command_accel_mm_s2, std::hypot(acc_x[k], acc_y[k]));
  if (degree < 2) {
    r.peak_command_accel_mm_s2 = std::numeric_limits<double>::infinity();
    r.status = CompensationStatus::unbounded_command_acceleration;
    r.message = "degree 1 B-splines have velocity steps at the knots; use --degree 2 or more";
  } else {
    r.status = CompensationStatus::ok;
  }
}

}  // namespace amctl::compensation::detail
