#pragma once
// Robustness of a PI loop around the powder bed G(s) against additive uncertainty
// G + Delta, ||Delta||_inf < eps (seed 002, section 4): the margin is 1/||C (1 + G C)^-1||_inf
// when the nominal loop is stable (Vidyasagar / Glover; Curtain & Zwart Lemma 9.3.12).
#include <complex>
#include <vector>

#include <Eigen/Dense>

#include "amctl/control/pid.hpp"
#include "amctl/control/state_space.hpp"
#include "amctl/thermal/powder_bed_tf.hpp"

namespace amctl::thermal {

/// The PI of seed 002, C(s) = kp (Ti s + 1)/(Ti s), kp in W/(m^2 K), Ti in s: a
/// control::PidGains in the standard form, control::PidGains::standard(kp, ti_s).
/// Throws amctl::Error naming kp or Ti unless kp is finite and > 0, Ti finite and > 0 and the
/// derivative action zero (the margins below are for a PI).
void require_realisable_pi(const control::PidGains& pi);

/// How the modes beyond N are represented in a modal realisation.
enum class TailModel {
  none,         ///< G_N itself
  static_gain,  ///< D = (G - G_N)(0): exact at s = 0, error ~ |s| T2 (residualisation)
  one_pole,     ///< a/(s + b) matching the tail's value T0 and slope -T2 at s = 0: error ~ |s|^2
};

/// Modal realisation of G_N (diagonal A = poles, B = 1, C = residues), plus the tail model.
/// T0 = sum_{k>N} r_k/|p_k|, T2 = sum_{k>N} r_k/p_k^2; the one-pole tail has b = T0/T2 (a mean
/// of the omitted |p_k|, so >= |p_{N+1}|) and a = T0 b.
[[nodiscard]] control::StateSpace modal_realization(const PowderBedTf& g, int modes,
                                                    TailModel tail = TailModel::none);

/// Closed loop from reference w to control u, T = C (1 + G C)^-1, for a plant in state space
/// (SISO, any D with 1 + kp D != 0) under the PI controller.
[[nodiscard]] control::StateSpace control_sensitivity(const control::StateSpace& plant,
                                                      const control::PidGains& pi);

/// Result of a frequency-domain peak search.
struct PeakResult {
  double peak = 0.0;         ///< sup |T(j w)| found
  double omega_rad_s = 0.0;  ///< where (inf if the sup is the limit w -> inf)
  int evaluations = 0;
};

/// Options for the grid-plus-refinement peak search.
struct SweepOptions {
  double w_min_rad_s = 1e-8;
  double w_max_rad_s = 1e10;
  int points_per_decade = 200;
  double rel_tol = 1e-12;  ///< golden-section tolerance in log w
};

/// sup_w |f(j w)| for f given by a callable, by a dense log grid and golden-section refinement
/// around every local maximum of the grid; also compares with f at the grid ends.
template <class F>
PeakResult sweep_peak(F&& f, const SweepOptions& opt);

/// H-infinity norm of a stable SISO state-space system by bisection on the imaginary-axis
/// eigenvalues of the Hamiltonian (Boyd, Balakrishnan & Kabamba 1989). Throws amctl::Error for
/// a system that is not SISO and InternalError if A is not Hurwitz. `rel_tol` is the relative bracket width on exit.
[[nodiscard]] double hinf_norm_hamiltonian(const control::StateSpace& sys,
                                           double rel_tol = 1e-9);

/// Number of closed-loop poles of 1/(1 + L) in the closed right half plane by the argument
/// principle (Nyquist): the winding of 1 + L(s) along the D-contour (the imaginary axis from
/// -j R to j R, indented to the right around s = 0 with radius eps, closed by the arc of radius
/// R), tracked with adaptive subdivision so no phase step exceeds 0.3 rad. `open_loop_rhp_poles`
/// is P, the poles of L strictly inside the indented contour. Works for irrational L such as
/// the exact G C. Returns Z = N_clockwise + P.
template <class F>
int nyquist_closed_loop_rhp_poles(F&& loop, int open_loop_rhp_poles = 0, double eps = 1e-9,
                                  double big_r = 1e12);

/// Everything the sls-margins command reports.
struct MarginReport {
  double length_m = 0.0;
  int modes = 0;
  // ||G - G_N||_inf: numerical sweep, a-priori bound (tail sum), the paper's printed (13).
  double hinf_g_minus_gn = 0.0;
  double hinf_g_minus_gn_omega = 0.0;
  double bound_tail = 0.0;
  double bound_printed_13 = 0.0;
  // Margins 1/||C S||_inf.
  double margin_on_gn_sweep = 0.0;        ///< sweep of the rational G_N loop
  double margin_on_gn_hamiltonian = 0.0;  ///< Hamiltonian bisection of the same loop
  double margin_on_g_sweep = 0.0;         ///< sweep of the exact irrational G
  double margin_on_g_hamiltonian = 0.0;   ///< Hamiltonian on G_M + static correction, M large
  int hamiltonian_modes_for_g = 0;
  double peak_omega_gn = 0.0;
  double peak_omega_g = 0.0;
  // Stability of the loops: largest real part of the closed-loop poles (G_N and G_M).
  double max_pole_real_gn = 0.0;
  double max_pole_real_gm = 0.0;
  bool stable_gn = false;
  bool stable_gm = false;
  int nyquist_rhp_poles_g = -1;  ///< closed-loop RHP poles of the exact G loop (argument principle)
  // Theorem 2: eps_a - delta (with delta = ||G - G_N||_inf) must not exceed the margin on G.
  double theorem2_lower_bound = 0.0;
  bool theorem2_applicable = false;  ///< delta < eps_a, the hypothesis of Theorem 2
  bool theorem2_holds = false;       ///< applicable and margin on G >= eps_a - delta
  // Best achievable margin (Glover): Hankel singular value of (G_u^beta)~, r0/(2|beta|).
  double beta = 0.0;
  double hankel_best_margin = 0.0;
};

/// Best achievable additive-uncertainty margin with closed-loop poles left of Re s = beta < 0:
/// the Hankel singular value of the anti-stable part of G(s + beta), r0/(2|beta|).
[[nodiscard]] double hankel_best_margin(const PowderBedTf& g, double beta);

/// All the figures above. `beta` (< 0) sets the stability margin for the Hankel value;
/// `hamiltonian_modes` the truncation used for the second evaluation of the margin on G.
[[nodiscard]] MarginReport compute_margins(const PowderBedTf& g, const control::PidGains& pi,
                                           int modes, double beta = -0.01,
                                           int hamiltonian_modes = 60);

}  // namespace amctl::thermal

#include "amctl/thermal/detail/sweep_peak.ipp"
