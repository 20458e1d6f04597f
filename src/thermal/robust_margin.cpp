#include "amctl/thermal/robust_margin.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Eigenvalues>

#include "amctl/core/error.hpp"

namespace amctl::thermal {

using cd = std::complex<double>;

void require_realisable_pi(const control::PidGains& pi) {
  require_positive("kp (PI proportional gain, W/(m^2 K))", pi.kp());
  const double ti_s = pi.integral_time_s();
  if (!std::isfinite(ti_s) || ti_s <= 0.0)
    throw Error("Ti (PI integral time) must be finite and > 0 s for a realisable PI, got " +
                std::to_string(ti_s));
  if (pi.kd_s() != 0.0)
    throw Error("the margins are for a PI: the derivative gain must be 0, got " +
                std::to_string(pi.kd_s()));
}

namespace {
// A SISO system's matrices as plain vectors and a scalar: the Hamiltonian and the loop
// algebra below were written (and their printed figures fixed) with these operand types.
struct Siso {
  Eigen::MatrixXd a;
  Eigen::VectorXd b;
  Eigen::RowVectorXd c;
  double d = 0.0;
};

Siso siso_parts(const control::StateSpace& s) {
  if (!s.is_siso())
    throw Error("the loop and H-infinity computations need a SISO system, got " +
                std::to_string(s.inputs()) + " inputs and " + std::to_string(s.outputs()) +
                " outputs");
  return Siso{s.A(), s.B().col(0), s.C().row(0), s.D()(0, 0)};
}

// sum_{k>n} 1/k^4: 64 exact terms and the Euler-Maclaurin remainder
// 1/(3m^3) - 1/(2m^4) + 1/(3m^5) - 1/(6m^7) from m = n + 64.
double quartic_tail(int n) {
  constexpr int kExplicit = 64;
  double sum = 0.0;
  for (int k = n + kExplicit; k > n; --k) {
    const double k2 = double(k) * double(k);
    sum += 1.0 / (k2 * k2);
  }
  const double m = double(n + kExplicit), m2 = m * m, m3 = m2 * m;
  return sum + 1.0 / (3.0 * m3) - 1.0 / (2.0 * m2 * m2) + 1.0 / (3.0 * m3 * m2) -
         1.0 / (6.0 * m3 * m3 * m);
}
}  // namespace

control::StateSpace modal_realization(const PowderBedTf& g, int modes, TailModel tail) {
  AMCTL_CHECK(modes >= 0, "modes must be >= 0");
  const int n = modes + 1 + (tail == TailModel::one_pole ? 1 : 0);
  Siso ss;
  ss.a = Eigen::MatrixXd::Zero(n, n);
  ss.b = Eigen::VectorXd::Ones(n);
  ss.c = Eigen::RowVectorXd(n);
  for (int k = 0; k <= modes; ++k) {
    ss.a(k, k) = g.pole(k);
    ss.c(k) = g.residue(k);
  }
  ss.d = 0.0;
  const double t0 = g.modal_tail_bound(modes);
  if (tail == TailModel::static_gain) ss.d = t0;
  if (tail == TailModel::one_pole) {
    // r_k/p_k^2 = 2 r0 (l/(pi a))^4 / k^4 with (l/(pi a))^2 = 1/|p_1|.
    const double p1 = std::abs(g.pole(1));
    const double t2 = g.residue(1) / (p1 * p1) * quartic_tail(modes);
    const double b = t0 / t2;
    ss.a(n - 1, n - 1) = -b;
    ss.c(n - 1) = t0 * b;
  }
  return control::StateSpace::siso(std::move(ss.a), ss.b, ss.c, ss.d);
}

control::StateSpace control_sensitivity(const control::StateSpace& plant_ss,
                                        const control::PidGains& pi) {
  require_realisable_pi(pi);
  const Siso plant = siso_parts(plant_ss);
  const auto n = plant.a.rows();
  const double kp = pi.kp(), d = plant.d;
  const double den = 1.0 + kp * d;
  AMCTL_CHECK(std::abs(den) > 1e-12, "algebraic loop 1 + kp D is singular");
  const double h = 1.0 / den;
  // u = h kp w + Kx x + Ki xi,  y = Cg x + d u,  xi' = w - y,  x' = A x + B u.
  const Eigen::RowVectorXd kx = -h * kp * plant.c;
  const double ki = h * kp / pi.integral_time_s();
  Siso t;
  t.a = Eigen::MatrixXd::Zero(n + 1, n + 1);
  t.a.topLeftCorner(n, n) = plant.a + plant.b * kx;
  t.a.topRightCorner(n, 1) = plant.b * ki;
  t.a.bottomLeftCorner(1, n) = -plant.c - d * kx;
  t.a(n, n) = -d * ki;
  t.b = Eigen::VectorXd(n + 1);
  t.b.head(n) = plant.b * (h * kp);
  t.b(n) = 1.0 - d * h * kp;
  t.c = Eigen::RowVectorXd(n + 1);
  t.c.head(n) = kx;
  t.c(n) = ki;
  t.d = h * kp;
  return control::StateSpace::siso(std::move(t.a), t.b, t.c, t.d);
}

namespace {

double max_real_eig(const Eigen::MatrixXd& a) {
  Eigen::EigenSolver<Eigen::MatrixXd> es(a, false);
  return es.eigenvalues().real().maxCoeff();
}

// True if the Hamiltonian of `sys` at level gamma has an eigenvalue on the imaginary axis,
// i.e. gamma is a singular value of T(j w) for some real w.
//
// Numerically, the pair of imaginary eigenvalues that coalesces as gamma rises to the norm is
// ill-conditioned (error ~ sqrt(eps ||H||)), and lightly damped closed-loop poles put genuine
// off-axis eigenvalues close to the axis. So eigenvalues within a loose band around the axis are
// candidates, and a candidate counts only if |T(j Im lambda)| >= gamma (Bruinsma & Steinbuch
// 1990 use the same test on the candidate frequencies).
bool has_imaginary_eigenvalue(const control::StateSpace& full, const Siso& sys, double gamma) {
  const auto n = sys.a.rows();
  const double r = sys.d * sys.d - gamma * gamma;  // R = S = D^2 - gamma^2 < 0
  Eigen::MatrixXd h(2 * n, 2 * n);
  const Eigen::MatrixXd ct = sys.c.transpose();
  h.topLeftCorner(n, n) = sys.a - (sys.d / r) * sys.b * sys.c;
  h.topRightCorner(n, n) = -(gamma / r) * sys.b * sys.b.transpose();
  h.bottomLeftCorner(n, n) = (gamma / r) * ct * sys.c;
  h.bottomRightCorner(n, n) = -sys.a.transpose() + (sys.d / r) * ct * sys.b.transpose();
  Eigen::EigenSolver<Eigen::MatrixXd> es(h, false);
  const double scale = h.cwiseAbs().maxCoeff();
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i) {
    const cd lam = es.eigenvalues()(i);
    if (lam.imag() < 0.0) continue;
    if (std::abs(lam.real()) > 1e-3 * std::abs(lam) + 1e-12 * scale) continue;
    if (std::abs(control::transfer_siso(full, cd(0.0, lam.imag()))) >= gamma * (1.0 - 1e-9))
      return true;
  }
  return false;
}

}  // namespace

double hinf_norm_hamiltonian(const control::StateSpace& full, double rel_tol) {
  const Siso sys = siso_parts(full);
  auto eval = [&](cd s) { return control::transfer_siso(full, s); };
  AMCTL_CHECK(max_real_eig(sys.a) < 0.0, "H-infinity norm needs a Hurwitz A");
  // Lower bound from |D|, |T(0)| and |T| at the modulus of each pole (Boyd et al.).
  double lo = std::max(std::abs(sys.d), std::abs(eval(cd(0.0, 0.0))));
  Eigen::EigenSolver<Eigen::MatrixXd> es(sys.a, false);
  for (Eigen::Index i = 0; i < es.eigenvalues().size(); ++i)
    lo = std::max(lo, std::abs(eval(cd(0.0, std::abs(es.eigenvalues()(i))))));
  double hi = 2.0 * lo + 1e-300;
  while (has_imaginary_eigenvalue(full, sys, hi)) {
    lo = hi;
    hi *= 2.0;
    AMCTL_CHECK(std::isfinite(hi), "H-infinity bisection diverged");
  }
  lo = std::max(lo, std::abs(sys.d) * (1.0 + 1e-15));
  while (hi - lo > rel_tol * lo) {
    const double mid = 0.5 * (lo + hi);
    if (has_imaginary_eigenvalue(full, sys, mid))
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

double hankel_best_margin(const PowderBedTf& g, double beta) {
  if (!std::isfinite(beta) || beta >= 0.0)
    throw Error("beta (closed-loop stability margin) must be finite and < 0, got " +
                std::to_string(beta));
  // G(s + beta) has its integrator pole at s = -beta > 0; the anti-stable part r0/(s + beta)
  // has Hankel singular value r0 / (2 |beta|) (Gramians of (A, B, C) = (-beta, 1, r0)).
  return g.residue(0) / (2.0 * std::abs(beta));
}

MarginReport compute_margins(const PowderBedTf& g, const control::PidGains& pi, int modes,
                             double beta, int hamiltonian_modes) {
  require_realisable_pi(pi);
  if (modes < 1) throw Error("modes (N, modal truncation order) must be >= 1, got " +
                             std::to_string(modes));
  if (hamiltonian_modes < modes) hamiltonian_modes = modes;
  MarginReport r;
  r.length_m = g.length_m();
  r.modes = modes;
  r.beta = beta;
  r.hankel_best_margin = hankel_best_margin(g, beta);

  // Scale the sweep to the plant: from well below the loop crossover to far above the
  // N-th modal pole and the PI zero.
  SweepOptions opt;
  const double w_top = std::max({std::abs(g.pole(std::max(hamiltonian_modes, modes) + 1)),
                                 10.0 / pi.integral_time_s(), 1.0});
  opt.w_min_rad_s = 1e-9;
  opt.w_max_rad_s = 1e4 * w_top;

  // ||G - G_N||_inf.
  auto diff = [&](cd s) {
    cd v = g.eval_regular(s);
    for (int k = 1; k <= modes; ++k) v -= g.residue(k) / (s - g.pole(k));
    return v;
  };
  const auto pd = sweep_peak(diff, opt);
  const double at_zero = std::abs(diff(cd(0.0, 0.0)));
  r.hinf_g_minus_gn = std::max(pd.peak, at_zero);
  r.hinf_g_minus_gn_omega = at_zero >= pd.peak * (1.0 - 1e-9) ? 0.0 : pd.omega_rad_s;
  r.bound_tail = g.modal_tail_bound(modes);
  r.bound_printed_13 = g.printed_bound_13(modes);

  // Way 1: frequency sweeps of |C (1 + G C)^-1|.
  auto cs_gn = [&](cd s) {
    const cd c = pi.transfer(s);
    return c / (1.0 + g.eval_modal(s, modes) * c);
  };
  auto cs_g = [&](cd s) {
    const cd c = pi.transfer(s);
    return c / (1.0 + g.eval(s) * c);
  };
  const auto p_gn = sweep_peak(cs_gn, opt);
  const auto p_g = sweep_peak(cs_g, opt);
  r.margin_on_gn_sweep = 1.0 / std::max(p_gn.peak, pi.kp());  // sup includes w -> inf limit kp
  r.margin_on_g_sweep = 1.0 / std::max(p_g.peak, pi.kp());
  r.peak_omega_gn = p_gn.omega_rad_s;
  r.peak_omega_g = p_g.omega_rad_s;

  // Way 2: Hamiltonian bisection on state-space realisations of the same loops.
  const control::StateSpace t_gn =
      control_sensitivity(modal_realization(g, modes, TailModel::none), pi);
  r.max_pole_real_gn = max_real_eig(t_gn.A());
  r.stable_gn = r.max_pole_real_gn < 0.0;
  const control::StateSpace t_gm =
      control_sensitivity(modal_realization(g, hamiltonian_modes, TailModel::one_pole), pi);
  r.max_pole_real_gm = max_real_eig(t_gm.A());
  r.stable_gm = r.max_pole_real_gm < 0.0;
  r.hamiltonian_modes_for_g = hamiltonian_modes;
  r.margin_on_gn_hamiltonian =
      r.stable_gn ? 1.0 / hinf_norm_hamiltonian(t_gn) : 0.0;
  r.margin_on_g_hamiltonian =
      r.stable_gm ? 1.0 / hinf_norm_hamiltonian(t_gm) : 0.0;
  if (!r.stable_gn) r.margin_on_gn_sweep = 0.0;
  if (!r.stable_gm) r.margin_on_g_sweep = 0.0;

  r.nyquist_rhp_poles_g = nyquist_closed_loop_rhp_poles(
      [&](cd s) { return g.eval(s) * pi.transfer(s); }, 0, 1e-9, 1e12);
  if (r.nyquist_rhp_poles_g != 0) r.margin_on_g_sweep = 0.0;

  r.theorem2_lower_bound = r.margin_on_gn_sweep - r.hinf_g_minus_gn;
  r.theorem2_applicable = r.hinf_g_minus_gn < r.margin_on_gn_sweep;
  r.theorem2_holds = r.theorem2_applicable &&
                     r.margin_on_g_sweep >= r.theorem2_lower_bound * (1.0 - 1e-9);
  return r;
}

}  // namespace amctl::thermal
