// The finite-element plant's time step (fe_plant.hpp): Newton on the theta scheme's residual
// (inexact, its update shifted to conserve energy and mapped through the nodal enthalpy, with
// backtracking and a predictor), and the linear solver (CG with a reused AMG hierarchy).
#include <deal.II/base/timer.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>

#include <limits>
#include <sstream>

#include "fe_plant.hpp"

namespace amctl::sls3d::fe {

void FePlant::enthalpy_update(const Vec& t_owned, Vec& delta) const {
  const double ts = spec_.melting.solidus_c, w = spec_.melting.liquidus_c - spec_.melting.solidus_c;
  const auto n = std::size_t(delta.locally_owned_size());
  const double* t = t_owned.begin();
  const double* a = node_a_.begin();
  const double* b = node_b_.begin();
  const double* bs = node_bs_.begin();
  double* d = delta.begin();
  for (std::size_t i = 0; i < n; ++i) {
    if (a[i] <= 0.0 || b[i] <= 0.0 || d[i] == 0.0) continue;  // constrained, or no latent heat
    const double sigma = std::clamp(bs[i] / b[i], 0.0, 1.0);
    auto phi = [&](double x) { return a[i] * x + b[i] * std::max(sigma, smoothstep((x - ts) / w)); };
    auto slope = [&](double x) {
      const double f = smoothstep((x - ts) / w);
      return a[i] + (f > sigma ? b[i] * smoothstep_slope((x - ts) / w) / w : 0.0);
    };
    const double target = phi(t[i]) + slope(t[i]) * d[i];
    // phi rises with a slope of at least a_i, and b_i (1 - sigma) at most over the latent range.
    double lo = (target - b[i]) / a[i], hi = (target - b[i] * sigma) / a[i];
    double x = std::clamp(t[i] + d[i], lo, hi);
    for (int k = 0; k < 60 && hi - lo > 1e-12 * (1.0 + std::abs(x)); ++k) {
      const double g = phi(x) - target;
      if (g == 0.0) break;
      (g > 0 ? hi : lo) = x;
      const double next = x - g / slope(x);
      x = (next > lo && next < hi) ? next : 0.5 * (lo + hi);
    }
    d[i] = x - t[i];
  }
}

[[noreturn]] void FePlant::fail(const std::string& message) const {
  std::ostringstream os;
  os << "step " << step_count_ << ": " << message;
  throw Error(os.str());
}

void FePlant::solve_linear(Vec& x, const Vec& b, double rel_tol, int& iterations, const char* what) {
  const double bnorm = b.l2_norm();
  if (bnorm == 0.0) {
    x = 0;
    return;
  }
  Timer timer;
  rel_tol = std::clamp(rel_tol, spec_.solver.linear_rel_tol, 0.1);
  const double tol = rel_tol * bnorm;
  const double decades = -std::log10(rel_tol);
  unsigned last_step = 0;
  double last_residual = 0;
  // CG from zero with `prec`, at most max_it iterations; false when it did not converge.
  auto run = [&](const auto& prec, unsigned max_it) {
    SolverControl control(max_it, tol);
    SolverCG<Vec> cg(control);
    x = 0;
    try {
      cg.solve(jac_, x, b, prec);
      last_step = control.last_step();
      iterations += int(last_step);
      n_cg_ += long(last_step);
      return true;
    } catch (const SolverControl::NoConvergence& e) {
      last_step = e.last_step;
      last_residual = e.last_residual;
      iterations += int(last_step);
      n_cg_ += long(last_step);
      return false;
    }
  };
  const unsigned max_it = unsigned(spec_.solver.max_linear_iterations);
  bool ok = false, rebuilt = false;
  switch (spec_.solver.preconditioner) {
    case SolverSettings::Preconditioner::amg: {
      // The hierarchy is reused while the mesh is unchanged (the Jacobian changes little from
      // step to step) and rebuilt every 25 matrices, when CG converged clearly slower per decade
      // than right after a rebuild, or when it does not converge with the old one within twice
      // that rate (a stale hierarchy costs at most about twice a fresh solve).
      auto rebuild = [&] {
        Timer amg_timer;
        amg_ = std::make_unique<TrilinosWrappers::PreconditionAMG>();
        TrilinosWrappers::PreconditionAMG::AdditionalData data;
        data.elliptic = true;
        data.smoother_sweeps = 2;
        amg_->initialize(jac_, data);
        amg_dofs_ = dof_.n_dofs();
        amg_age_ = 0;
        amg_rate_ = -1;
        rebuilt = true;
        t_amg_ += amg_timer.wall_time();
        ++n_amg_;
      };
      const bool fresh = !amg_ || amg_dofs_ != dof_.n_dofs() || amg_age_ >= 25 ||
                         (amg_rate_ > 0 && last_rate_ > 1.5 * amg_rate_ + 0.5);
      if (fresh) rebuild();
      ++amg_age_;
      const unsigned stale_cap = unsigned(std::ceil(decades * (2.0 * std::max(amg_rate_, 1.0) + 1.0))) + 5;
      ok = run(*amg_, fresh ? max_it : std::min(max_it, stale_cap));
      if (!ok && !fresh) {
        rebuild();
        ok = run(*amg_, max_it);
      }
      break;
    }
    case SolverSettings::Preconditioner::jacobi: {
      TrilinosWrappers::PreconditionJacobi jac;
      jac.initialize(jac_);
      ok = run(jac, max_it);
      break;
    }
    case SolverSettings::Preconditioner::ssor: {
      TrilinosWrappers::PreconditionSSOR ssor;
      ssor.initialize(jac_);
      ok = run(ssor, max_it);
      break;
    }
  }
  if (!ok) {
    std::ostringstream os;
    os << "the linear solver (CG) did not converge for the " << what << ": " << last_step
       << " iterations, residual " << last_residual << " > " << tol << " (|b| = " << bnorm << ")";
    fail(os.str());
  }
  last_rate_ = double(std::max(1u, last_step)) / std::max(decades, 1.0);
  if (rebuilt) amg_rate_ = last_rate_;
  cons_.distribute(x);
  t_linear_ += timer.wall_time();
}

StepReport FePlant::step(const StepInput& in) {
  Timer timer;
  ++step_count_;
  StepReport r;
  const double dt = in.dt_s, theta = in.theta > 0 ? in.theta : spec_.theta;
  Vec b(owned_, comm_), inputs(owned_, comm_), vh(owned_, comm_), vk(owned_, comm_);
  Vec delta(owned_, comm_), res(owned_, comm_), trial(owned_, comm_), base(owned_, comm_);
  Vec step_vec(owned_, comm_), t_try(owned_, relevant_, comm_), ones(owned_, comm_), j_ones(owned_, comm_);
  // The predictor: the last step's change carried on (a linear extrapolation in time), tried
  // when the previous step's temperatures are on the same mesh.
  const bool predict = have_prev_ && prev_dt_ > 0;
  if (spec_.melting.enabled) build_nodal_model();
  // At T^n: v_h, v_k (and the Jacobian, unless the iteration starts at the predictor).
  // b = M H(T^n) - (1 - theta) dt (K T^n + L^n) + dt (S + U).
  const Sums old = assemble(t_, theta * dt, vh, vk, !predict);
  // The nodal enthalpies at T^n, for the energy the step moves (the balance's scale); vh holds
  // them at the current temperatures whenever vh_at_t.
  Vec h_start(owned_, comm_);
  h_start = vh;
  bool vh_at_t = true;
  Timer input_timer;
  const auto [laser_rate, flux_rate] = assemble_inputs(in, inputs);
  t_inputs_ += input_timer.wall_time();
  b = vh;
  b.add(-(1.0 - theta) * dt, vk, dt, inputs);
  r.laser_j = laser_rate * dt;
  r.top_flux_j = flux_rate * dt;
  for (const LaserPass& p : in.passes) r.laser_nominal_j += p.power_w * (p.t1_s - p.t0_s);
  // R(T) = M H(T) + theta dt (K T + L(T)) - b.
  auto form_residual = [&] {
    res = vh;
    res.add(theta * dt, vk, -1.0, b);
    return res.l2_norm();
  };
  // Rounding level of the residual (relative to the stored enthalpy, whatever the domain's size).
  const double floor = 1e-13 * std::abs(old.enthalpy) /
                       std::sqrt(std::max<double>(1.0, double(dof_.n_dofs())));
  Sums now = old;
  // The tolerances are relative to the residual at T^n (what the step has to change),
  // whichever guess the iteration starts from.
  double norm = form_residual();
  r.residual_initial = norm;
  const double target = std::max(spec_.solver.newton_rel_tol * norm, floor);
  bool have_matrix = !predict;
  // The step's starting temperatures, kept for the predictor of the next step.
  Vec t_start(owned_, comm_);
  t_start = t_;
  if (predict) {
    trial = t_;
    trial.add(-1.0, t_prev_);
    trial.sadd(dt / prev_dt_, 1.0, t_start);
    t_try = trial;
    const Sums at = assemble(t_try, 0.0, vh, vk, false);
    const double predicted = form_residual();
    if (std::isfinite(predicted) && predicted < norm) {
      t_ = t_try;
      now = at;
      vh_at_t = true;
      norm = predicted;
      ++n_predicted_;
    } else {
      norm = r.residual_initial;  // the loop assembles at T^n with the Jacobian
      vh_at_t = false;  // vh holds the rejected prediction; T is still T^n
    }
  }
  // Energy scale of the step: what enters and leaves. The step has converged when |R| is
  // below the target, or when it is 1e-5 of where it started (the temperatures then carry a
  // 1e-5 share of the step's change) and the energy defect sum_i R_i (what the balance of
  // the step misses) is below 1e-7 of that scale (the balance is asked to 1e-6).
  const double energy_scale = dt * (std::abs(laser_rate) + std::abs(flux_rate) + std::abs(old.loss)) +
                              1e-15 * std::abs(old.enthalpy);
  auto converged = [&] {
    if (norm <= target) return true;
    if (norm > 1e-5 * r.residual_initial) return false;
    const double defect = res.mean_value() * double(res.size());
    return std::abs(defect) <= 1e-7 * energy_scale;
  };
  int it = 0;
  const bool trace = std::getenv("AMCTL_SLS3D_PROFILE") != nullptr && Utilities::MPI::this_mpi_process(comm_) == 0;
  // Inexact Newton (Eisenstat and Walker's second choice of forcing term): the linear solve
  // asks for a reduction eta = 0.9 (|R_k| / |R_k-1|)^2, never more than 0.1 nor below what
  // the Newton target needs; the first iteration takes the contraction of the last step's
  // first (a step without latent heat is almost linear: one tight solve; a melting step is not).
  double previous_norm = 0.0, eta = 0.0;
  while (!converged()) {
    if (it >= spec_.solver.max_newton_iterations) {
      std::ostringstream os;
      os << "t = " << in.t_s + dt << " s: Newton did not converge in " << it
         << " iterations, residual " << norm << " J > " << target << " J (initial " << r.residual_initial
         << " J)";
      fail(os.str());
    }
    if (!have_matrix) {
      now = assemble(t_, theta * dt, vh, vk, true);
      norm = form_residual();
      vh_at_t = true;
    }
    if (it == 0) {
      eta = last_contraction_ > 0 ? 0.9 * last_contraction_ * last_contraction_ : 0.0;
    } else {
      const double ew = 0.9 * (norm / previous_norm) * (norm / previous_norm);
      eta = 0.9 * eta * eta > 0.1 ? std::max(ew, 0.9 * eta * eta) : ew;
    }
    eta = std::min(eta, 0.1);
    eta = std::max(eta, 0.5 * target / norm);
    res *= -1.0;
    delta = 0;
    solve_linear(delta, res, eta, r.linear_iterations, "Newton update");
    // An inexact solve leaves a residual whose sum is an energy defect of the step. The rows of
    // K sum to zero, so a uniform shift c of the update changes that sum by c 1'J1 only (the
    // capacities and the losses' slopes): shifted so that the linearised step conserves energy
    // exactly, whatever the linear tolerance (hanging nodes take the shift with their masters).
    {
      ones = 1.0;
      jac_.vmult(j_ones, ones);
      jac_.vmult(trial, delta);
      trial -= res;  // J delta - (-R) : the linear solve's residual
      cons_.set_zero(j_ones);
      cons_.set_zero(trial);
      const double capacity = j_ones.mean_value() * double(j_ones.size());
      const double defect = trial.mean_value() * double(trial.size());
      if (capacity > 0) delta.add(-defect / capacity, ones);
    }
    // Backtracking on |R|: the latent heat makes H' jump at the melting range.
    double lambda = 1.0, next = 0;
    base = t_;
    for (int k = 0; k < 8; ++k) {
      trial = base;
      if (spec_.melting.enabled) {
        // Along the enthalpy: lambda shortens the linear update before it is mapped.
        step_vec = delta;
        step_vec *= lambda;
        enthalpy_update(base, step_vec);
        cons_.distribute(step_vec);  // hanging nodes follow their masters
        trial += step_vec;
      } else {
        trial.add(lambda, delta);
      }
      t_try = trial;
      now = assemble(t_try, 0.0, vh, vk, false);
      next = form_residual();
      if (std::isfinite(next) && (next < norm || k == 7)) break;
      lambda *= 0.5;
    }
    if (!std::isfinite(next)) {
      std::ostringstream os;
      os << "t = " << in.t_s + dt << " s: the Newton update diverged (residual not finite)";
      fail(os.str());
    }
    t_ = t_try;
    vh_at_t = true;
    if (trace)
      std::fprintf(stderr, "  step %d newton %d: |R| %.3e -> %.3e (lambda %g, eta %.1e, %d CG total)\n", step_count_,
                   it, norm, next, lambda, eta, r.linear_iterations);
    if (it == 0) last_contraction_ = next / norm;
    previous_norm = norm;
    norm = next;
    have_matrix = false;
    ++it;
    ++n_newton_;
  }
  t_prev_ = t_start;
  prev_dt_ = dt;
  have_prev_ = true;
  r.newton_iterations = it;
  r.residual_final = norm;
  r.enthalpy_change_j = now.enthalpy - old.enthalpy;
  r.radiation_j = dt * (theta * now.radiation + (1 - theta) * old.radiation);
  r.convection_j = dt * (theta * now.convection + (1 - theta) * old.convection);
  const double losses = r.radiation_j + r.convection_j;
  r.balance_error_j = r.enthalpy_change_j - (r.laser_j + r.top_flux_j - losses);
  // Relative to the energy that moved in the step: what entered and left, and the enthalpy
  // moved from node to node, sum_i |m_i (H_i(T) - H_i(T^n))| (a step without inputs still
  // conducts heat: its net change is zero to rounding, its gross change is not); when next to
  // nothing moves, to the rounding of the stored enthalpy (the balance cannot be closer).
  double moved = 0.0;  // T is still T^n when vh does not hold it
  if (vh_at_t) {
    h_start.sadd(-1.0, 1.0, vh);
    moved = h_start.l1_norm();
  }
  const double inputs_j = std::abs(r.laser_j) + std::abs(r.top_flux_j) + std::abs(losses);
  const double scale = std::max({std::abs(r.enthalpy_change_j) + inputs_j, moved + inputs_j,
                                 1e-12 * std::abs(old.enthalpy)});
  r.balance_rel_error = scale > 0 ? std::abs(r.balance_error_j) / scale : 0.0;
  const auto [changed, de] = update_states();
  r.cells_consolidated = changed;
  r.densification_j = de;
  double tmax = -std::numeric_limits<double>::infinity();
  for (const auto i : owned_) tmax = std::max(tmax, double(t_[i]));
  r.max_temp_c = Utilities::MPI::max(tmax, comm_);
  solve_seconds_ += timer.wall_time();
  return r;
}

}  // namespace amctl::sls3d::fe
