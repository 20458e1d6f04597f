#pragma once
// Internals of amctl::compensation (not installed): the exact inverse filter, the sample grid,
// the FBF solver and the contour distance.
#include <cstddef>
#include <deque>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>

#include "amctl/compensation/compensate.hpp"
#include "amctl/control/discretize.hpp"

namespace amctl::compensation::detail {

/// Uniform command grid t_k = t0 + k h, k < count; the first move starts at lead_steps.
struct Grid {
  double t0 = 0.0, h = 0.0;
  std::size_t count = 0, lead_steps = 0;
  [[nodiscard]] double t(std::size_t k) const { return t0 + static_cast<double>(k) * h; }
};

struct Segment {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
/// Throws amctl::Error for bad options (naming them).
void validate_options(const CompensationOptions& o);
/// CompensationOptions::judge_machine_accel: the machine's acceleration limit into `r` and,
/// when an "ok" command's peak is above it, status machine_accel_limit_exceeded.
void judge_machine_accel(CompensationResult& r, const machine::Machine& m, const CompensationOptions& o);
/// The automatic tail: 5 time constants of the slowest mode of model and plant, in [0.05, 1] s.
double auto_tail_s(const CompensationOptions& o);
/// The slowest decay rate over the modes [1/s]: z w, or w (z - sqrt(z^2 - 1)) for an
/// overdamped mode (+inf for a rigid model).
double slowest_decay_rate_per_s(const dynamics::AxisModel& m);

/// x_b = x + d x'' + C z,  z' = A z + B x''  (the proper rational H(s) of compensate.hpp in
/// controllable canonical form, frequency-scaled for conditioning). Throws amctl::Error if
/// H is unstable or marginally stable (the inverse does not exist as a bounded signal).
class InverseFilter {
 public:
  explicit InverseFilter(const dynamics::AxisModel& model);
  [[nodiscard]] int states() const { return static_cast<int>(A_.rows()); }
  /// deg N - deg P: 0 = feedthrough (an undamped mode), 1 = one damped mode, ...
  [[nodiscard]] int relative_degree() const { return relative_degree_; }
  /// Time for the inverse's slowest pole to decay by e^-30 [s].
  [[nodiscard]] double settle_s() const { return settle_s_; }
  const Eigen::MatrixXd& A() const { return A_; }
  const Eigen::VectorXd& B() const { return B_; }
  const Eigen::RowVectorXd& C() const { return C_; }
  double d() const { return d_; }

 private:
  Eigen::MatrixXd A_;
  Eigen::VectorXd B_;
  Eigen::RowVectorXd C_;
  double d_ = 0.0;
  int relative_degree_ = 0;
  double settle_s_ = 0.0;
};

struct InverseRun {
  double peak_accel_mm_s2 = 0.0;  ///< over the samples (right limits)
  bool velocity_jump = false, accel_jump = false, jerk_jump = false;
  bool unbounded_accel = false, unbounded_jerk = false;
};

/// Fills r.t_s, x/y_cmd_mm, x/y_des_mm, lead_in_s, tail_s over `grid`.
InverseRun run_inverse(std::span<const plan::PlannedMove> moves, const InverseFilter& fx,
                       const InverseFilter& fy, const Grid& grid, CompensationResult& r);

/// Polynomial pieces of the cardinal B-spline of `degree`: element i holds the ascending
/// coefficients in u of B(i + u), 0 <= u < 1, i = 0..degree (support [0, degree + 1]).
std::vector<std::vector<double>> cardinal_bspline_pieces(int degree);

/// The first basis function N_0(t) = B_p(t / T), T = q h, sampled at m h, m = 0 .. (p+1) q.
struct Basis {
  int p = 3, q = 1;              ///< degree, samples per knot
  double T = 0.0, h = 0.0;       ///< knot spacing, sample step [s]
  std::vector<double> val, acc;  ///< N_0 and N_0'' [1/s^2] at the samples
};
Basis make_basis(int p, int q, double h);
/// The model's nozzle response to the command N_0 (from rest) at samples m h, exact, truncated
/// once the vibration after the support has decayed below 1e-10 of its peak.
std::vector<double> filtered_response(const dynamics::AxisModel& model, const Basis& b);

/// FBF's grid: knot spacing q h, M knots (the end spline from knot M - p), lead-in, tail.
struct FbfLayout {
  Grid grid;
  int q = 1, M = 0;
  double settle_s = 0.0;  ///< 4 / (zeta w) of the model's slowest mode [s]
};
/// The part of the layout the first move settles (everything but M and the grid's count).
FbfLayout fbf_layout_start(const plan::PlannedMove& first, const CompensationOptions& o);
FbfLayout fbf_layout(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
                     double auto_tail_s);
/// r.t_s, r.x_des_mm, r.y_des_mm on the grid.
void sample_desired(std::span<const plan::PlannedMove> moves, const Grid& grid, CompensationResult& r);

/// The normal matrix of n shifted copies (by q samples) of R over `rows` samples, factorised
/// in place (banded Cholesky, bandwidth (len(R) - 1) / q).
class BandedCholesky {
 public:
  BandedCholesky(const std::vector<double>& R, int q, int n, std::size_t rows);
  /// The sum of the normal matrices of several responses (robust FBF: one per model).
  BandedCholesky(const std::vector<std::vector<double>>& Rs, int q, int n, std::size_t rows);
  /// A lower band the caller built (row-wise: band[j (L+1) + (i - j + L)] = G(j, i) for
  /// j - L <= i <= j), factorised in place.
  BandedCholesky(std::vector<double> band, int n, int L);
  /// Solves G c = b in place.
  void solve(std::vector<double>& c) const;

 private:
  void factorise();
  int n_ = 0, L_ = 0;
  std::vector<double> band_;
};

/// The command of one axis at the K samples: x0 plus the first J basis functions weighted by
/// c and the last M - J (the end spline) by x1 - x0; and its acceleration. Basis function j
/// starts at sample j q.
void assemble_axis(const Basis& basis, int q, int J, int M, std::size_t K, const std::vector<double>& c,
                   double x0, double x1, std::vector<double>& xb, std::vector<double>& acc);

/// FBF's peak command acceleration (both axes) and status: degree 1 has velocity steps.
void set_fbf_status(CompensationResult& r, const std::vector<double>& acc_x,
                    const std::vector<double>& acc_y, int degree);

/// A window of a sample sequence: index k (absolute) at data[k - base]; contiguous, so loops
/// over it vectorise; the consumed front is dropped by compaction (amortised O(1)).
class SlidingBuffer {
 public:
  /// Pointer to absolute indices [k, k + n), zero-filled as needed (k >= base()).
  double* span(std::size_t k, std::size_t n) {
    const std::size_t end = k - base_ + off_ + n;
    if (end > v_.size()) v_.resize(end, 0.0);
    return v_.data() + (k - base_ + off_);
  }
  [[nodiscard]] const double* data_at(std::size_t k) const { return v_.data() + (k - base_ + off_); }
  [[nodiscard]] std::size_t end() const { return base_ + v_.size() - off_; }
  [[nodiscard]] std::size_t base() const { return base_; }
  [[nodiscard]] double front_or_zero() const { return off_ < v_.size() ? v_[off_] : 0.0; }
  void push_back(double x) { v_.push_back(x); }
  [[nodiscard]] std::size_t size() const { return v_.size() - off_; }
  void pop_front() {
    if (off_ < v_.size()) ++off_;
    else v_.push_back(0.0), ++off_;  // keep end() >= base()
    ++base_;
    if (off_ > 4096 && off_ * 2 > v_.size()) {
      v_.erase(v_.begin(), v_.begin() + static_cast<std::ptrdiff_t>(off_));
      off_ = 0;
    }
  }

 private:
  std::vector<double> v_;
  std::size_t off_ = 0, base_ = 0;
};

/// LPFBF on one axis, streaming: push the desired samples of the grid one by one; every full
/// window is solved as soon as its samples (and p knots more) are in; finish() solves the last
/// window with the end spline fixed. Holds O(window + len(R)) samples.
class LpfbfAxis {
 public:
  LpfbfAxis(const dynamics::AxisModel& model, const Basis& basis, int window_knots, int overlap_knots,
            double x0);
  void push(double x_des_mm);
  void finish(std::size_t K, int M, double x_end_mm);
  /// Command samples final so far (removed from the axis).
  std::vector<double> take_command() { return std::exchange(out_cmd_, {}); }
  std::vector<double> take_accel() { return std::exchange(out_acc_, {}); }
  [[nodiscard]] std::size_t windows() const { return windows_; }
  [[nodiscard]] std::size_t max_held_samples() const { return held_max_; }

 private:
  void solve_window(int n, std::size_t rows, const BandedCholesky& chol, int keep);
  void commit(double w);
  void emit(std::size_t upto);
  /// The tails' contribution C E_k at samples [base_, base_ + n) into g (E_base_ not moved).
  void tail_over(std::size_t n, std::vector<double>& g) const;
  /// E_base_ moved from base_ to base_ + 1 (the injection at base_ included).
  void advance_tail();

  std::vector<double> R_, val_, acc_;
  // R_[m] for m >= H_ is C Phi^(m - H_) eS_ (free vibration after the spline's support): the
  // committed splines' tails are carried as one state E (injected c_j eS at sample j q + H_)
  // instead of being added sample by sample (H_ = R_.size() if that factorisation fails).
  std::size_t H_ = 0;
  Eigen::MatrixXd Phi_;
  Eigen::RowVectorXd C_;
  Eigen::VectorXd eS_, E_base_, tmp_;
  std::deque<Eigen::VectorXd> inj_;  ///< state injections at samples base_, base_ + 1, ...
  /// The kept coefficients of a full window as one linear map of the window's residual:
  /// rows [0, step) of G^-1 Phi^T (G = Phi^T Phi the window's normal matrix), built once, so a
  /// window costs one (step x rows) product instead of Phi^T r and two triangular solves.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> keep_gain_;
  Eigen::VectorXd residual_, kept_;
  int p_ = 3, q_ = 1, nw_ = 1, step_ = 1;
  double x0_ = 0.0;
  BandedCholesky window_;
  int s_ = 0;                  ///< first free coefficient
  std::size_t base_ = 0;       ///< grid index of the deques' front
  std::size_t pushed_ = 0, windows_ = 0, held_max_ = 0;
  SlidingBuffer des_, fixed_, cmd_, acc_out_;
  std::vector<double> out_cmd_, out_acc_;
};

/// LPFBF's window and overlap in knots from the options (automatic: W = max(0.25 s, 4
/// settling), O = W / 2); throws amctl::Error naming --window-s (shorter than the settling) or
/// --overlap-s (not in [settling / 2, W)).
std::pair<int, int> lpfbf_window_knots(const FbfLayout& lay, const CompensationOptions& o);

/// LPFBF over the whole plan (the grid and the end spline as FBF).
void run_lpfbf(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
               double auto_tail_s, Grid& grid, CompensationResult& r);

/// Robust FBF: FBF's least squares over the model and its frequency scaled by 0.8, 0.9, 1.1
/// and 1.2 (all modes), stacked.
void run_rfbf(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
              double auto_tail_s, Grid& grid, CompensationResult& r);

/// One axis of the collocation problem (collocation.cpp, docs section 2d): the state
/// [x_b, v_b / w_r, modal states] with S' = F S + G u, u = x_b'' / w_r^2, and its
/// Hermite-Simpson defect over one step h, scaled by 2h/3:
///     P S_k + Q S_k+1 + e1 u_k + e2 u_k+1 = 0.
class CollocationAxis {
 public:
  CollocationAxis(const dynamics::AxisModel& model, double w_ref_per_s, double h);
  [[nodiscard]] int states() const { return static_cast<int>(P_.rows()); }
  const Eigen::MatrixXd& P() const { return P_; }
  const Eigen::MatrixXd& Q() const { return Q_; }
  const Eigen::VectorXd& e1() const { return e1_; }
  const Eigen::VectorXd& e2() const { return e2_; }
  /// The nozzle position x_b + sum of the modal displacements as a row over the states.
  const Eigen::RowVectorXd& output_row() const { return out_; }

 private:
  Eigen::MatrixXd P_, Q_;
  Eigen::VectorXd e1_, e2_;
  Eigen::RowVectorXd out_;
};

/// Direct collocation with IPOPT (both axes in one NLP per window): fills the grid, the
/// command, the solver fields and the status of r (the status says when IPOPT failed, and the
/// command is then left empty).
void run_collocation(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
                     double auto_tail_s, Grid& grid, CompensationResult& r);

/// FBF: fills the grid, the command and the basis fields of r.
void run_fbf(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
             double auto_tail_s, Grid& grid, CompensationResult& r);

}  // namespace amctl::compensation::detail
