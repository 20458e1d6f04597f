// Limited-preview filtered B-splines (Duan, Yoon, Okwudire 2018; docs/compensation.md,
// section 3).
//
// The FBF command of fbf.cpp, x_b = x_0 + sum_j c_j N_j + (x_end - x_0) S, with the weights
// computed by a receding horizon instead of one global least squares: a window of n_w knots
// (W = n_w T) starting at knot s solves
//     min_c  sum_{k in [s q, (s + n_w) q)} (x_des[k] - x_0 - f[k] - sum_{i < n_w} c_{s+i} R_0[k - (s+i) q])^2
// where f holds the response of the coefficients already fixed (j < s), keeps the first
// n_w - n_o coefficients (W - O seconds of command), adds their responses to f and moves on
// by n_w - n_o knots. The window's normal matrix depends only on R_0, n_w and q (uniform
// knots, time-invariant model): it is factorised once (banded Cholesky) and every window costs
// one right-hand side and two triangular solves. Only the window's samples and the tail of f
// are held. The last window (fewer free coefficients, the end spline S fixed) has its own
// matrix, factorised once at the end.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/control/discretize.hpp"
#include "amctl/core/error.hpp"
#include "detail.hpp"

namespace amctl::compensation::detail {

BandedCholesky::BandedCholesky(const std::vector<double>& R, int q, int n, std::size_t rows)
    : BandedCholesky(std::vector<std::vector<double>>{R}, q, n, rows) {}

BandedCholesky::BandedCholesky(const std::vector<std::vector<double>>& Rs, int q, int n, std::size_t rows)
    : n_(n) {
  std::size_t len_max = 1;
  for (const auto& R : Rs) len_max = std::max(len_max, R.size());
  L_ = static_cast<int>((len_max - 1) / static_cast<std::size_t>(q));
  const std::size_t W = static_cast<std::size_t>(L_) + 1;
  band_.assign(static_cast<std::size_t>(n) * W, 0.0);
  // G(j - l, j) = sum_R sum_{m < min(len - l q, rows - j q)} R[m] R[m + l q]
  double tr = 0.0;
  for (const auto& R : Rs) {
    const std::size_t len = R.size();
    for (int l = 0; l <= L_ && l < n; ++l) {
      const std::size_t shift = static_cast<std::size_t>(l) * static_cast<std::size_t>(q);
      if (shift >= len) break;
      double acc = 0.0;
      std::size_t m = 0;
      // Columns from the last to the first: rows_left grows, so the prefix grows.
      for (int j = n - 1; j >= l; --j) {
        const std::size_t jq = static_cast<std::size_t>(j) * static_cast<std::size_t>(q);
        const std::size_t rows_left = rows > jq ? rows - jq : 0;
        const std::size_t lim = std::min(len - shift, rows_left);
        for (; m < lim; ++m) acc += R[m] * R[m + shift];
        band_[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(L_ - l)] += acc;
        if (l == 0) tr += acc;
      }
    }
  }
  for (int j = 0; j < n; ++j)
    band_[static_cast<std::size_t>(j) * W + static_cast<std::size_t>(L_)] += 1e-13 * tr / n;
  factorise();
}

BandedCholesky::BandedCholesky(std::vector<double> band, int n, int L) : n_(n), L_(L), band_(std::move(band)) {
  factorise();
}

// G = L L^T in place; rows are contiguous, so each entry is one dot product.
void BandedCholesky::factorise() {
  const std::size_t W = static_cast<std::size_t>(L_) + 1;
  for (int j = 0; j < n_; ++j) {
    double* rj = &band_[static_cast<std::size_t>(j) * W];
    const int i0 = std::max(0, j - L_);
    for (int i = i0; i <= j; ++i) {
      const double* ri = &band_[static_cast<std::size_t>(i) * W];
      const int k0 = std::max(i0, i - L_);
      double sum = rj[i - j + L_];
      for (int k = k0; k < i; ++k) sum -= rj[k - j + L_] * ri[k - i + L_];
      if (i < j) {
        rj[i - j + L_] = sum / ri[L_];
      } else {
        if (!(sum > 0.0)) throw InternalError("fbf: the B-spline normal equations are not positive definite");
        rj[L_] = std::sqrt(sum);
      }
    }
  }
}

void BandedCholesky::solve(std::vector<double>& c) const {
  const std::size_t W = static_cast<std::size_t>(L_) + 1;
  for (int j = 0; j < n_; ++j) {
    const double* rj = &band_[static_cast<std::size_t>(j) * W];
    double sum = c[static_cast<std::size_t>(j)];
    for (int k = std::max(0, j - L_); k < j; ++k) sum -= rj[k - j + L_] * c[static_cast<std::size_t>(k)];
    c[static_cast<std::size_t>(j)] = sum / rj[L_];
  }
  for (int j = n_ - 1; j >= 0; --j) {
    const double* rj = &band_[static_cast<std::size_t>(j) * W];
    const double v = c[static_cast<std::size_t>(j)] / rj[L_];
    c[static_cast<std::size_t>(j)] = v;
    for (int k = std::max(0, j - L_); k < j; ++k) c[static_cast<std::size_t>(k)] -= rj[k - j + L_] * v;
  }
}

LpfbfAxis::LpfbfAxis(const dynamics::AxisModel& model, const Basis& basis, int window_knots,
                     int overlap_knots, double x0)
    : R_(filtered_response(model, basis)), val_(basis.val), acc_(basis.acc), p_(basis.p), q_(basis.q),
      nw_(window_knots), step_(window_knots - overlap_knots), x0_(x0),
      window_(R_, q_, nw_, static_cast<std::size_t>(nw_) * static_cast<std::size_t>(q_)) {
  H_ = R_.size();
  const std::size_t S = static_cast<std::size_t>(p_ + 1) * static_cast<std::size_t>(q_);
  const int n = static_cast<int>(model.A().rows());
  const std::size_t obs = static_cast<std::size_t>(4 * n);
  if (R_.size() > S + obs) {
    // The state after the support from the free vibration that follows (observability).
    Phi_ = control::discretize_polynomial(model.A(), model.B(), 1, basis.h).Phi;
    C_ = model.C();
    Eigen::MatrixXd O(static_cast<Eigen::Index>(obs), n);
    Eigen::VectorXd y(static_cast<Eigen::Index>(obs));
    Eigen::RowVectorXd row = C_;
    for (std::size_t i = 0; i < obs; ++i) {
      O.row(static_cast<Eigen::Index>(i)) = row;
      y(static_cast<Eigen::Index>(i)) = R_[S + i];
      row = row * Phi_;
    }
    eS_ = O.colPivHouseholderQr().solve(y);
    double peak = 0.0, err = 0.0;
    Eigen::VectorXd e = eS_;
    for (std::size_t m = 0; m < R_.size(); ++m) {
      peak = std::max(peak, std::abs(R_[m]));
      if (m >= S) {
        err = std::max(err, std::abs(R_[m] - C_ * e));
        e = Phi_ * e;
      }
    }
    if (err <= 1e-10 * peak) H_ = S;
  }
  E_base_ = Eigen::VectorXd::Zero(n);
  tmp_ = E_base_;
  // keep_gain_ = rows [0, step) of G^-1 Phi^T, column m = the first `step` entries of
  // G^-1 (Phi row m), Phi(m, i) = R[m - i q].
  const std::size_t rows = static_cast<std::size_t>(nw_) * static_cast<std::size_t>(q_);
  keep_gain_.resize(step_, static_cast<Eigen::Index>(rows));
  std::vector<double> z(static_cast<std::size_t>(nw_));
  for (std::size_t m = 0; m < rows; ++m) {
    for (int i = 0; i < nw_; ++i) {
      const std::size_t shift = static_cast<std::size_t>(i) * static_cast<std::size_t>(q_);
      z[static_cast<std::size_t>(i)] = (m >= shift && m - shift < R_.size()) ? R_[m - shift] : 0.0;
    }
    window_.solve(z);
    for (int i = 0; i < step_; ++i) keep_gain_(i, static_cast<Eigen::Index>(m)) = z[static_cast<std::size_t>(i)];
  }
  residual_.resize(static_cast<Eigen::Index>(rows));
  kept_.resize(step_);
}

void LpfbfAxis::tail_over(std::size_t n, std::vector<double>& g) const {
  g.assign(n, 0.0);
  if (H_ == R_.size()) return;
  Eigen::VectorXd E = E_base_, next(E.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (i < inj_.size()) E += inj_[i];
    g[i] = C_.dot(E);
    next.noalias() = Phi_ * E;
    E.swap(next);
  }
}

void LpfbfAxis::advance_tail() {
  if (H_ == R_.size()) return;
  if (!inj_.empty()) {
    E_base_ += inj_.front();
    inj_.pop_front();
  }
  tmp_.noalias() = Phi_ * E_base_;
  E_base_.swap(tmp_);
}

void LpfbfAxis::push(double x_des_mm) {
  des_.push_back(x_des_mm - x0_);
  ++pushed_;
  held_max_ = std::max(held_max_, des_.size());
  // A full window whose coefficients are all free ones (j < J = M - p, which holds while
  // pushed > (s + n_w + p) q + 1 whatever the grid's end turns out to be).
  const std::size_t need = static_cast<std::size_t>(s_ + nw_ + p_) * static_cast<std::size_t>(q_) + 1;
  if (pushed_ > need) solve_window(nw_, static_cast<std::size_t>(nw_) * static_cast<std::size_t>(q_), window_, step_);
}

void LpfbfAxis::solve_window(int n, std::size_t rows, const BandedCholesky& chol, int keep) {
  const std::size_t sq = static_cast<std::size_t>(s_) * static_cast<std::size_t>(q_);
  if (&chol == &window_ && keep == step_ && n == nw_ &&
      rows == static_cast<std::size_t>(keep_gain_.cols())) {  // a full window: the precomputed map
    std::vector<double> g;
    tail_over(rows, g);
    const double* d = des_.span(sq, rows);
    const double* f = fixed_.span(sq, rows);
    for (std::size_t k = 0; k < rows; ++k) residual_(static_cast<Eigen::Index>(k)) = d[k] - f[k] - g[k];
    kept_.noalias() = keep_gain_ * residual_;
    for (int i = 0; i < keep; ++i) commit(kept_(i));
    ++windows_;
    emit(static_cast<std::size_t>(s_) * static_cast<std::size_t>(q_));
    return;
  }
  std::vector<double> c(static_cast<std::size_t>(n), 0.0);
  std::vector<double> g;
  tail_over(rows, g);
  {
    double* f = fixed_.span(sq, rows);
    for (std::size_t k = 0; k < rows; ++k) f[k] += g[k];  // removed again below
  }
  for (int i = 0; i < n; ++i) {
    const std::size_t col = sq + static_cast<std::size_t>(i) * static_cast<std::size_t>(q_);
    const std::size_t n_m = std::min(R_.size(), sq + rows - col);
    const double* d = des_.span(col, n_m);  // all pushed (rows <= pushed)
    const double* f = fixed_.span(col, n_m);
    double sum = 0.0;
    for (std::size_t m = 0; m < n_m; ++m) sum += R_[m] * (d[m] - f[m]);
    c[static_cast<std::size_t>(i)] = sum;
  }
  {
    double* f = fixed_.span(sq, rows);
    for (std::size_t k = 0; k < rows; ++k) f[k] -= g[k];
  }
  chol.solve(c);
  for (int i = 0; i < keep; ++i) commit(c[static_cast<std::size_t>(i)]);
  ++windows_;
  emit(static_cast<std::size_t>(s_) * static_cast<std::size_t>(q_));
}

void LpfbfAxis::commit(double w) {
  const std::size_t col = static_cast<std::size_t>(s_) * static_cast<std::size_t>(q_);
  double* f = fixed_.span(col, H_);
  for (std::size_t m = 0; m < H_; ++m) f[m] += w * R_[m];
  if (H_ < R_.size()) {
    const std::size_t at = col + H_ - base_;
    while (inj_.size() <= at) inj_.push_back(Eigen::VectorXd::Zero(eS_.size()));
    inj_[at] += w * eS_;
  }
  double* x = cmd_.span(col, val_.size());
  double* a = acc_out_.span(col, val_.size());
  for (std::size_t m = 0; m < val_.size(); ++m) {
    x[m] += w * val_[m];
    a[m] += w * acc_[m];
  }
  ++s_;
}

void LpfbfAxis::emit(std::size_t upto) {
  while (base_ < upto) {
    out_cmd_.push_back(x0_ + cmd_.front_or_zero());
    out_acc_.push_back(acc_out_.front_or_zero());
    cmd_.pop_front();
    acc_out_.pop_front();
    fixed_.pop_front();
    des_.pop_front();
    advance_tail();
    ++base_;
  }
}

void LpfbfAxis::finish(std::size_t K, int M, double x_end_mm) {
  if (pushed_ != K) throw InternalError("lpfbf: the grid's sample count does not match the pushed samples");
  const int J = M - p_;
  while (J - s_ > nw_) solve_window(nw_, static_cast<std::size_t>(nw_) * static_cast<std::size_t>(q_), window_, step_);
  // The end spline S: coefficients J .. M-1 fixed at x_end - x_0.
  const int s_last = s_;
  {
    const double w = x_end_mm - x0_;
    const int keep_s = s_;
    s_ = J;
    for (int j = J; j < M; ++j) commit(w);  // advances s_ to M
    s_ = keep_s;
  }
  const int n = J - s_last;
  if (n > 0) {
    const std::size_t rows = K - static_cast<std::size_t>(s_last) * static_cast<std::size_t>(q_);
    const BandedCholesky last(R_, q_, n, rows);
    solve_window(n, rows, last, n);
  }
  emit(K);
}

std::pair<int, int> lpfbf_window_knots(const FbfLayout& lay, const CompensationOptions& o) {
  const double T = lay.q * lay.grid.h;
  const double settle = lay.settle_s;
  const double W = o.window_s > 0.0 ? o.window_s : std::max(0.25, 4.0 * settle);
  const double O = o.overlap_s >= 0.0 ? o.overlap_s : 0.5 * W;
  if (!(W >= settle))
    throw Error(fmt::format("--window-s {} is shorter than the model's settling time {:.4g} s "
                            "(4 / (zeta w) of its slowest mode); use a longer window", W, settle));
  if (!(O >= 0.0) || !(O < W))
    throw Error(fmt::format("--overlap-s: must be >= 0 and shorter than the window ({1} s), got {0}", O, W));
  // Without preview the last kept coefficients are fitted blind to what follows (overlap 0
  // gave a 4 mm error on the seed); half the settling time is enough there.
  if (O < 0.5 * settle)
    throw Error(fmt::format("--overlap-s {} is shorter than half the model's settling time ({:.4g} s): "
                            "the window's kept command would not see the path ahead", O, 0.5 * settle));
  const int nw = std::max(1, static_cast<int>(std::llround(W / T)));
  const int no = std::min(nw - 1, static_cast<int>(std::llround(O / T)));
  return {nw, no};
}

void run_lpfbf(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
               double auto_tail_s, Grid& grid, CompensationResult& r) {
  // The grid, the basis and the end spline exactly as FBF (fbf.cpp).
  FbfLayout lay = fbf_layout(moves, o, auto_tail_s);
  grid = lay.grid;
  const int p = o.degree, q = lay.q, M = lay.M, J = M - p;
  const double T = q * grid.h;
  const auto [nw, no] = lpfbf_window_knots(lay, o);
  r.knot_spacing_s = T;
  r.degree = p;
  r.basis_functions = static_cast<std::size_t>(std::max(J, 0));
  r.lead_in_s = static_cast<double>(grid.lead_steps) * grid.h;
  r.tail_s = grid.t(grid.count - 1) - moves.back().end_time_s();
  r.window_s = nw * T;
  r.overlap_s = no * T;
  const std::size_t K = grid.count;
  sample_desired(moves, grid, r);

  const Basis basis = make_basis(p, q, grid.h);
  std::vector<double>* cmd[2] = {&r.x_cmd_mm, &r.y_cmd_mm};
  const std::vector<double>* des[2] = {&r.x_des_mm, &r.y_des_mm};
  const dynamics::AxisModel* model[2] = {&o.model_x, &o.model_y};
  std::vector<double> acc[2];
  for (int a = 0; a < 2; ++a) {
    LpfbfAxis ax(*model[a], basis, nw, nw - no > 0 ? no : 0, (*des[a]).front());
    for (std::size_t k = 0; k < K; ++k) ax.push((*des[a])[k]);
    ax.finish(K, M, (*des[a]).back());
    *cmd[a] = ax.take_command();
    acc[a] = ax.take_accel();
    r.windows = ax.windows();
    r.max_held_samples = std::max(r.max_held_samples, ax.max_held_samples());
  }
  r.peak_command_accel_mm_s2 = 0.0;
  for (std::size_t k = 0; k < K; ++k)
    r.peak_command_accel_mm_s2 = std::max(r.peak_command_accel_mm_s2, std::hypot(acc[0][k], acc[1][k]));
  if (p < 2) {
    r.peak_command_accel_mm_s2 = std::numeric_limits<double>::infinity();
    r.status = CompensationStatus::unbounded_command_acceleration;
    r.message = "degree 1 B-splines have velocity steps at the knots; use --degree 2 or more";
  } else {
    r.status = CompensationStatus::ok;
  }
}

}  // namespace amctl::compensation::detail
