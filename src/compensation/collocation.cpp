// Direct collocation (Hermite-Simpson) of the base command with IPOPT (docs/compensation.md,
// section 2d). Per axis the state is [x_b, v_b / w_r, s_1 .. s_2m] (command position, scaled
// command velocity, the model's scaled modal states) and the control u = x_b'' / w_r^2, w_r
// a reference rate, so that every variable is a length of the order of the motion's (mm).
// With S' = F S + G u linear, the Hermite-Simpson defect of an interval of length h,
// multiplied by 2h/3 (derivation in the docs), is
//     (I + hF/2 + h^2F^2/12) S_k - (I - hF/2 + h^2F^2/12) S_k+1
//       + (hG/2 + h^2 FG/12) u_k + (hG/2 - h^2 FG/12) u_k+1 = 0,
// the control linear inside the interval (the seed's u_c = (u_1 + u_2)/2). The objective is
// the mean squared tracking error plus the effort (rho u)^2 (trapezoid rule), in um^2; the
// optional base acceleration bound is |(x_b'', y_b'')| <= A at every node, hence everywhere
// (the control is linear between nodes and the disc is convex).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include <IpIpoptApplication.hpp>
#include <IpSolveStatistics.hpp>
#include <IpTNLP.hpp>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/trajectory/trajectory.hpp"
#include "detail.hpp"

namespace amctl::compensation::detail {

CollocationAxis::CollocationAxis(const dynamics::AxisModel& model, double w_ref_per_s, double h) {
  const Eigen::MatrixXd Am = model.A();
  const Eigen::VectorXd Bm = model.B();
  const Eigen::RowVectorXd Cm = model.C();
  const int m = static_cast<int>(Am.rows());
  const int n = 2 + m;
  Eigen::MatrixXd F = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd G = Eigen::VectorXd::Zero(n);
  // x_b' = w_r v,  v' = w_r u,  s' = Am s + Bm x_b'' = Am s + (Bm w_r^2) u.
  F(0, 1) = w_ref_per_s;
  G(1) = w_ref_per_s;
  F.bottomRightCorner(m, m) = Am;
  G.tail(m) = Bm * (w_ref_per_s * w_ref_per_s);
  const Eigen::MatrixXd I = Eigen::MatrixXd::Identity(n, n);
  const Eigen::MatrixXd F2 = F * F;
  P_ = I + 0.5 * h * F + h * h / 12.0 * F2;
  Q_ = -(I - 0.5 * h * F + h * h / 12.0 * F2);
  e1_ = 0.5 * h * G + h * h / 12.0 * F * G;
  e2_ = 0.5 * h * G - h * h / 12.0 * F * G;
  out_ = Eigen::RowVectorXd::Zero(n);
  out_(0) = 1.0;
  out_.tail(m) = Cm;
}

namespace {

using Ipopt::Index;
using Ipopt::Number;

/// One window of the collocation problem, both axes. Variables node-major: at node k, axis
/// X's states and control, then Y's.
class CollocationNlp final : public Ipopt::TNLP {
 public:
  struct Setup {
    const CollocationAxis* axis[2]{};
    const double* des[2]{};  ///< desired nozzle position at the window's nodes [mm]
    int nodes = 0;
    std::vector<double> first[2];  ///< fixed first node (states and control) per axis
    bool fix_last = false;
    std::vector<double> last[2];  ///< fixed last node when fix_last
    std::vector<double> guess[2];  ///< start point, nodes x (states, control) per axis
    double w_track = 1.0;   ///< objective weight of a squared error [1/mm^2]
    double w_effort = 0.0;  ///< objective weight of a squared scaled control
    double inv_limit2 = 0.0;  ///< (w_r^2 / A)^2, 0 = no bound
  };

  explicit CollocationNlp(Setup s) : s_(std::move(s)) {
    for (int a = 0; a < 2; ++a) ns_[a] = s_.axis[a]->states();
    block_ = ns_[0] + 1 + ns_[1] + 1;
    off_[0] = 0;
    off_[1] = ns_[0] + 1;
    x_.assign(static_cast<std::size_t>(block_) * static_cast<std::size_t>(s_.nodes), 0.0);
  }

  [[nodiscard]] const std::vector<double>& solution() const { return x_; }
  [[nodiscard]] Ipopt::SolverReturn solver_return() const { return ret_; }
  [[nodiscard]] int index(int k, int a, int i) const { return k * block_ + off_[a] + i; }
  [[nodiscard]] int block() const { return block_; }
  [[nodiscard]] int offset(int a) const { return off_[a]; }

  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac, Index& nnz_h, IndexStyleEnum& style) override {
    const int K = s_.nodes;
    n = block_ * K;
    m = (K - 1) * (ns_[0] + ns_[1]) + (bounded() ? K : 0);
    nnz_jac = 0;
    for (int a = 0; a < 2; ++a) nnz_jac += (K - 1) * ns_[a] * (2 * ns_[a] + 2);
    if (bounded()) nnz_jac += 2 * K;
    nnz_h = 0;
    for (int a = 0; a < 2; ++a) nnz_h += K * (out_nz(a) * (out_nz(a) + 1) / 2 + 1);
    style = TNLP::C_STYLE;
    return true;
  }

  bool get_bounds_info(Index n, Number* x_l, Number* x_u, Index m, Number* g_l, Number* g_u) override {
    const double inf = 1e19;
    std::fill(x_l, x_l + n, -inf);
    std::fill(x_u, x_u + n, inf);
    for (int a = 0; a < 2; ++a)
      for (int i = 0; i <= ns_[a]; ++i) {
        x_l[index(0, a, i)] = x_u[index(0, a, i)] = s_.first[a][static_cast<std::size_t>(i)];
        // The command ends at rest at the end position (x_b, v_b); the nozzle's vibration is
        // left to the objective, which counts the whole tail.
        if (s_.fix_last && i < 2)
          x_l[index(s_.nodes - 1, a, i)] = x_u[index(s_.nodes - 1, a, i)] = s_.last[a][static_cast<std::size_t>(i)];
      }
    const int defects = (s_.nodes - 1) * (ns_[0] + ns_[1]);
    std::fill(g_l, g_l + defects, 0.0);
    std::fill(g_u, g_u + defects, 0.0);
    for (int r = defects; r < m; ++r) {
      g_l[r] = -inf;
      g_u[r] = 1.0;
    }
    return true;
  }

  bool get_starting_point(Index n, bool init_x, Number* x, bool, Number*, Number*, Index, bool, Number*) override {
    if (!init_x) return true;
    for (int k = 0; k < s_.nodes; ++k)
      for (int a = 0; a < 2; ++a)
        for (int i = 0; i <= ns_[a]; ++i)
          x[index(k, a, i)] = s_.guess[a][static_cast<std::size_t>(k * (ns_[a] + 1) + i)];
    (void)n;
    return true;
  }

  bool eval_f(Index, const Number* x, bool, Number& f) override {
    double sum = 0.0;
    for (int k = 0; k < s_.nodes; ++k) {
      const double w = weight(k);
      for (int a = 0; a < 2; ++a) {
        const double e = output(x, k, a) - s_.des[a][k];
        const double u = x[index(k, a, ns_[a])];
        sum += w * (s_.w_track * e * e + s_.w_effort * u * u);
      }
    }
    f = sum;
    return true;
  }

  bool eval_grad_f(Index n, const Number* x, bool, Number* g) override {
    std::fill(g, g + n, 0.0);
    for (int k = 0; k < s_.nodes; ++k) {
      const double w = weight(k);
      for (int a = 0; a < 2; ++a) {
        const double e = output(x, k, a) - s_.des[a][k];
        const Eigen::RowVectorXd& c = s_.axis[a]->output_row();
        for (int i = 0; i < ns_[a]; ++i) g[index(k, a, i)] += 2.0 * w * s_.w_track * e * c(i);
        g[index(k, a, ns_[a])] += 2.0 * w * s_.w_effort * x[index(k, a, ns_[a])];
      }
    }
    return true;
  }

  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    int r = 0;
    for (int k = 0; k + 1 < s_.nodes; ++k)
      for (int a = 0; a < 2; ++a) {
        const CollocationAxis& ax = *s_.axis[a];
        const int n = ns_[a];
        for (int i = 0; i < n; ++i) {
          double d = ax.e1()(i) * x[index(k, a, n)] + ax.e2()(i) * x[index(k + 1, a, n)];
          for (int j = 0; j < n; ++j) d += ax.P()(i, j) * x[index(k, a, j)] + ax.Q()(i, j) * x[index(k + 1, a, j)];
          g[r++] = d;
        }
      }
    if (bounded())
      for (int k = 0; k < s_.nodes; ++k) {
        const double ux = x[index(k, 0, ns_[0])], uy = x[index(k, 1, ns_[1])];
        g[r++] = (ux * ux + uy * uy) * s_.inv_limit2;
      }
    return true;
  }

  bool eval_jac_g(Index, const Number* x, bool, Index, Index, Index* row, Index* col, Number* v) override {
    int r = 0, e = 0;
    for (int k = 0; k + 1 < s_.nodes; ++k)
      for (int a = 0; a < 2; ++a) {
        const CollocationAxis& ax = *s_.axis[a];
        const int n = ns_[a];
        for (int i = 0; i < n; ++i, ++r) {
          for (int j = 0; j < n; ++j) {
            if (v == nullptr) {
              row[e] = r, col[e] = index(k, a, j), ++e;
              row[e] = r, col[e] = index(k + 1, a, j), ++e;
            } else {
              v[e++] = ax.P()(i, j);
              v[e++] = ax.Q()(i, j);
            }
          }
          if (v == nullptr) {
            row[e] = r, col[e] = index(k, a, n), ++e;
            row[e] = r, col[e] = index(k + 1, a, n), ++e;
          } else {
            v[e++] = ax.e1()(i);
            v[e++] = ax.e2()(i);
          }
        }
      }
    if (bounded())
      for (int k = 0; k < s_.nodes; ++k, ++r)
        for (int a = 0; a < 2; ++a) {
          if (v == nullptr) row[e] = r, col[e] = index(k, a, ns_[a]), ++e;
          else v[e++] = 2.0 * x[index(k, a, ns_[a])] * s_.inv_limit2;
        }
    return true;
  }

  bool eval_h(Index, const Number*, bool, Number obj_factor, Index, const Number* lambda, bool, Index,
              Index* row, Index* col, Number* v) override {
    const int defects = (s_.nodes - 1) * (ns_[0] + ns_[1]);
    int e = 0;
    for (int k = 0; k < s_.nodes; ++k) {
      const double w = weight(k);
      for (int a = 0; a < 2; ++a) {
        const Eigen::RowVectorXd& c = s_.axis[a]->output_row();
        // The output's Hessian 2 w c^T c over the states the output reads (lower triangle).
        for (int i = 0; i < ns_[a]; ++i) {
          if (c(i) == 0.0) continue;
          for (int j = 0; j <= i; ++j) {
            if (c(j) == 0.0) continue;
            if (v == nullptr) row[e] = index(k, a, i), col[e] = index(k, a, j);
            else v[e] = obj_factor * 2.0 * w * s_.w_track * c(i) * c(j);
            ++e;
          }
        }
        const int u = index(k, a, ns_[a]);
        if (v == nullptr) {
          row[e] = u, col[e] = u;
        } else {
          v[e] = obj_factor * 2.0 * w * s_.w_effort;
          if (bounded()) v[e] += lambda[defects + k] * 2.0 * s_.inv_limit2;
        }
        ++e;
      }
    }
    return true;
  }

  void finalize_solution(Ipopt::SolverReturn status, Index n, const Number* x, const Number*, const Number*,
                         Index, const Number*, const Number*, Number, const Ipopt::IpoptData*,
                         Ipopt::IpoptCalculatedQuantities*) override {
    ret_ = status;
    x_.assign(x, x + n);
  }

 private:
  [[nodiscard]] bool bounded() const { return s_.inv_limit2 > 0.0; }
  [[nodiscard]] double weight(int k) const { return (k == 0 || k + 1 == s_.nodes) ? 0.5 : 1.0; }
  [[nodiscard]] double output(const Number* x, int k, int a) const {
    const Eigen::RowVectorXd& c = s_.axis[a]->output_row();
    double y = 0.0;
    for (int i = 0; i < ns_[a]; ++i) y += c(i) * x[index(k, a, i)];
    return y;
  }
  [[nodiscard]] int out_nz(int a) const {
    int z = 0;
    for (int i = 0; i < ns_[a]; ++i) z += s_.axis[a]->output_row()(i) != 0.0 ? 1 : 0;
    return z;
  }

  Setup s_;
  int ns_[2]{}, off_[2]{}, block_ = 0;
  std::vector<double> x_;
  Ipopt::SolverReturn ret_ = Ipopt::UNASSIGNED;
};

const char* solver_return_name(Ipopt::SolverReturn s) {
  switch (s) {
    case Ipopt::SUCCESS: return "Solve_Succeeded";
    case Ipopt::MAXITER_EXCEEDED: return "Maximum_Iterations_Exceeded";
    case Ipopt::CPUTIME_EXCEEDED: return "Maximum_CpuTime_Exceeded";
    case Ipopt::STOP_AT_TINY_STEP: return "Search_Direction_Becomes_Too_Small";
    case Ipopt::STOP_AT_ACCEPTABLE_POINT: return "Solved_To_Acceptable_Level";
    case Ipopt::LOCAL_INFEASIBILITY: return "Infeasible_Problem_Detected";
    case Ipopt::USER_REQUESTED_STOP: return "User_Requested_Stop";
    case Ipopt::DIVERGING_ITERATES: return "Diverging_Iterates";
    case Ipopt::RESTORATION_FAILURE: return "Restoration_Failed";
    case Ipopt::ERROR_IN_STEP_COMPUTATION: return "Error_In_Step_Computation";
    case Ipopt::INVALID_NUMBER_DETECTED: return "Invalid_Number_Detected";
    case Ipopt::TOO_FEW_DEGREES_OF_FREEDOM: return "Not_Enough_Degrees_Of_Freedom";
    case Ipopt::INVALID_OPTION: return "Invalid_Option";
    case Ipopt::OUT_OF_MEMORY: return "Insufficient_Memory";
    case Ipopt::INTERNAL_ERROR: return "Internal_Error";
    default: return "Unknown_Error";
  }
}

}  // namespace

void run_collocation(std::span<const plan::PlannedMove> moves, const CompensationOptions& o,
                     double auto_tail_s, Grid& grid, CompensationResult& r) {
  if (!(o.effort_weight_s2 >= 0.0) || !std::isfinite(o.effort_weight_s2))
    throw Error(fmt::format("--effort-weight-s2: must be >= 0, got {}", o.effort_weight_s2));
  if (o.max_solver_iterations < 1)
    throw Error(fmt::format("--max-iterations: must be >= 1, got {}", o.max_solver_iterations));
  const double h = 1.0 / o.sample_rate_hz;
  const double decay = std::min(slowest_decay_rate_per_s(o.model_x), slowest_decay_rate_per_s(o.model_y));
  const double settle = std::isfinite(decay) && decay > 0 ? 4.0 / decay : 1.0;
  const double lead = o.lead_in_s >= 0.0 ? o.lead_in_s : std::min(1.0, settle);
  const double tail = o.tail_s >= 0.0 ? o.tail_s : auto_tail_s;
  const double t_begin = moves.front().start_time_s, t_end = moves.back().end_time_s();
  grid.h = h;
  grid.lead_steps = static_cast<std::size_t>(std::ceil(lead / h - 1e-9));
  grid.t0 = t_begin - static_cast<double>(grid.lead_steps) * h;
  grid.count = static_cast<std::size_t>(std::ceil((t_end + tail - grid.t0) / h - 1e-9)) + 1;
  r.lead_in_s = static_cast<double>(grid.lead_steps) * h;
  r.tail_s = grid.t(grid.count - 1) - t_end;
  sample_desired(moves, grid, r);
  const std::size_t K = grid.count;

  // Windows: W nodes each, the last O of which are preview (solved, then re-solved by the
  // next window, which starts from the state at the first of them).
  const double w_s = o.window_s > 0.0 ? o.window_s : std::max(1.0, 10.0 * settle);
  const double o_s = o.overlap_s >= 0.0 ? o.overlap_s : std::max(0.25, 3.0 * settle);
  if (o.window_s > 0.0 && o.window_s < settle)
    throw Error(fmt::format("--window-s {} is shorter than the model's settling time ({:.4g} s)", o.window_s, settle));
  if (o.overlap_s >= 0.0 && !(o.overlap_s < w_s))
    throw Error(fmt::format("--overlap-s: must be >= 0 and shorter than the window ({1} s), got {0}", o.overlap_s, w_s));
  if (o.overlap_s >= 0.0 && o.overlap_s < 0.5 * settle)
    throw Error(fmt::format("--overlap-s {} is shorter than half the model's settling time ({:.4g} s)",
                            o.overlap_s, 0.5 * settle));
  const int Wn = std::max(3, static_cast<int>(std::lround(w_s / h)) + 1);
  const int On = std::clamp(static_cast<int>(std::lround(o_s / h)), 1, Wn - 2);
  r.window_s = (Wn - 1) * h;
  r.overlap_s = On * h;

  const double f_max = std::max(o.model_x.max_natural_frequency_hz(), o.model_y.max_natural_frequency_hz());
  const double w_ref = 2.0 * M_PI * f_max;
  const CollocationAxis ax[2] = {CollocationAxis(o.model_x, w_ref, h), CollocationAxis(o.model_y, w_ref, h)};
  const std::vector<double>* des[2] = {&r.x_des_mm, &r.y_des_mm};
  std::vector<double>* cmd[2] = {&r.x_cmd_mm, &r.y_cmd_mm};
  std::vector<double> state[2];  // every node's states and control, per axis
  for (int a = 0; a < 2; ++a) {
    cmd[a]->assign(K, 0.0);
    state[a].assign(K * static_cast<std::size_t>(ax[a].states() + 1), 0.0);
  }
  // Start point: the plan itself as the command (x_b = x, v_b = v, u = a), no vibration.
  {
    trajectory::Cursor cur(moves);
    for (std::size_t k = 0; k < K; ++k) {
      const trajectory::AxisState st = cur.evaluate(grid.t(k));
      for (int a = 0; a < 2; ++a) {
        double* s = &state[a][k * static_cast<std::size_t>(ax[a].states() + 1)];
        s[0] = st.pos_mm[static_cast<std::size_t>(a)];
        s[1] = st.vel_mm_s[static_cast<std::size_t>(a)] / w_ref;
        s[ax[a].states()] = st.acc_mm_s2[static_cast<std::size_t>(a)] / (w_ref * w_ref);
      }
    }
    for (int a = 0; a < 2; ++a) {  // rest at both ends
      const int n1 = ax[a].states() + 1;
      for (int i = 1; i < n1; ++i) {
        state[a][static_cast<std::size_t>(i)] = 0.0;
        state[a][(K - 1) * static_cast<std::size_t>(n1) + static_cast<std::size_t>(i)] = 0.0;
      }
    }
  }
  const double span_s = static_cast<double>(K - 1) * h;
  const double limit = o.max_base_accel_mm_s2;
  const bool bounded = std::isfinite(limit) && limit > 0.0;

  r.effort_weight_s2 = o.effort_weight_s2;
  r.max_base_accel_mm_s2 = bounded ? limit : std::numeric_limits<double>::infinity();
  if (bounded) {
    // Rest to rest over the distance d in the time T needs at least 4 d / T^2 (bang-bang).
    const double d = std::hypot(r.x_des_mm.back() - r.x_des_mm.front(), r.y_des_mm.back() - r.y_des_mm.front());
    const double need = 4.0 * d / (span_s * span_s);
    if (need > limit) {
      r.solver_status = "not_solved";
      r.status = CompensationStatus::infeasible;
      r.message = fmt::format(
          "no command within --max-base-accel-mm-s2 {} moves {:.6g} mm from rest to rest in {:.6g} s "
          "(lead-in, motion and tail); that needs at least {:.6g} mm/s^2", limit, d, span_s, need);
      return;
    }
  }

  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false, false);
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetIntegerValue("max_iter", o.max_solver_iterations);
  // The objective is in um^2; errors of millimetres (a tight bound) make it 1e6 and more, and
  // IPOPT then stalls: 1e-3 keeps the scaled problem O(1) over the range measured (bounds
  // 400 .. 1e9 mm/s^2 on the seed case all converge; docs section 2d).
  app->Options()->SetNumericValue("obj_scaling_factor", 1e-3);
  app->Options()->SetNumericValue("tol", 1e-8);
  app->Options()->SetStringValue("mu_strategy", "adaptive");
  app->Options()->SetStringValue("jac_c_constant", "yes");
  if (!bounded) app->Options()->SetStringValue("hessian_constant", "yes");
  std::istringstream no_options_file;  // never read ./ipopt.opt: the result depends on the input only
  if (app->Initialize(no_options_file) != Ipopt::Solve_Succeeded)
    throw Error("collocation: IPOPT failed to initialise");

  r.solver_status = "Solve_Succeeded";
  r.status = CompensationStatus::ok;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = std::min(K - 1, start + static_cast<std::size_t>(Wn) - 1);
    const bool last = end == K - 1;
    CollocationNlp::Setup s;
    s.nodes = static_cast<int>(end - start + 1);
    for (int a = 0; a < 2; ++a) {
      const std::size_t n1 = static_cast<std::size_t>(ax[a].states() + 1);
      s.axis[a] = &ax[a];
      s.des[a] = des[a]->data() + start;
      s.first[a].assign(state[a].begin() + static_cast<std::ptrdiff_t>(start * n1),
                        state[a].begin() + static_cast<std::ptrdiff_t>((start + 1) * n1));
      if (start == 0) {  // at rest at the start position
        std::fill(s.first[a].begin(), s.first[a].end(), 0.0);
        s.first[a][0] = (*des[a]).front();
      }
      s.fix_last = last;
      if (last) {
        s.last[a].assign(n1, 0.0);
        s.last[a][0] = (*des[a]).back();
      }
      s.guess[a].assign(state[a].begin() + static_cast<std::ptrdiff_t>(start * n1),
                        state[a].begin() + static_cast<std::ptrdiff_t>((end + 1) * n1));
    }
    // Mean squared error [um^2] + effort (rho x_b'')^2 [um^2], rho = effort_weight_s2.
    s.w_track = 1e6 / span_s * h;
    const double rho_u = o.effort_weight_s2 * w_ref * w_ref;  // rho x_b'' = rho w_r^2 u
    s.w_effort = 1e6 / span_s * h * rho_u * rho_u;
    s.inv_limit2 = bounded ? std::pow(w_ref * w_ref / limit, 2) : 0.0;
    Ipopt::SmartPtr<CollocationNlp> nlp = new CollocationNlp(std::move(s));
    const Ipopt::ApplicationReturnStatus st = app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(GetRawPtr(nlp)));
    ++r.windows;
    r.solver_iterations += static_cast<std::size_t>(Ipopt::IsValid(app->Statistics()) ? app->Statistics()->IterationCount() : 0);
    const Ipopt::SolverReturn ret = nlp->solver_return();
    const bool ok = st == Ipopt::Solve_Succeeded || st == Ipopt::Solved_To_Acceptable_Level;
    if (!ok) {
      r.solver_status = solver_return_name(ret);
      r.status = ret == Ipopt::LOCAL_INFEASIBILITY ? CompensationStatus::infeasible : CompensationStatus::solver_failed;
      r.message = fmt::format(
          "IPOPT stopped with {} in window {} ({:.4f} to {:.4f} s){}", r.solver_status, r.windows,
          grid.t(start), grid.t(end),
          ret == Ipopt::LOCAL_INFEASIBILITY
              ? ": no command within the base acceleration limit reaches the end at rest; raise "
                "--max-base-accel-mm-s2"
              : "");
      return;
    }
    if (st == Ipopt::Solved_To_Acceptable_Level) r.solver_status = "Solved_To_Acceptable_Level";
    const std::size_t keep_to = last ? end : end - static_cast<std::size_t>(On);
    const std::vector<double>& x = nlp->solution();
    for (std::size_t k = start; k <= keep_to; ++k)
      for (int a = 0; a < 2; ++a) {
        const int n1 = ax[a].states() + 1;
        for (int i = 0; i < n1; ++i)
          state[a][k * static_cast<std::size_t>(n1) + static_cast<std::size_t>(i)] =
              x[static_cast<std::size_t>(nlp->index(static_cast<int>(k - start), a, i))];
      }
    if (last) break;
    start = keep_to;
  }

  // The command, its acceleration and the defects of the kept solution.
  r.peak_command_accel_mm_s2 = 0.0;
  double worst_defect = 0.0, worst_over = 0.0;
  std::vector<double>* acc[2] = {&r.x_cmd_accel_mm_s2, &r.y_cmd_accel_mm_s2};
  for (int a = 0; a < 2; ++a) acc[a]->assign(K, 0.0);
  for (std::size_t k = 0; k < K; ++k) {
    double acc2 = 0.0;
    for (int a = 0; a < 2; ++a) {
      const int n = ax[a].states();
      const double* s = &state[a][k * static_cast<std::size_t>(n + 1)];
      (*cmd[a])[k] = s[0];
      (*acc[a])[k] = s[n] * w_ref * w_ref;
      acc2 += std::pow(s[n] * w_ref * w_ref, 2);
      if (k + 1 < K) {
        const double* s1 = s + n + 1;
        for (int i = 0; i < n; ++i) {
          double d = ax[a].e1()(i) * s[n] + ax[a].e2()(i) * s1[n];
          for (int j = 0; j < n; ++j) d += ax[a].P()(i, j) * s[j] + ax[a].Q()(i, j) * s1[j];
          worst_defect = std::max(worst_defect, std::abs(d));
        }
      }
    }
    r.peak_command_accel_mm_s2 = std::max(r.peak_command_accel_mm_s2, std::sqrt(acc2));
  }
  if (bounded) worst_over = std::max(0.0, r.peak_command_accel_mm_s2 / limit - 1.0);
  r.max_defect_mm = worst_defect;
  if (bounded && worst_over > 1e-6) {
    r.status = CompensationStatus::base_accel_limit_exceeded;
    r.message = fmt::format("the solution exceeds --max-base-accel-mm-s2 {} by {:.3g} %", limit, 100.0 * worst_over);
  }
}

}  // namespace amctl::compensation::detail
