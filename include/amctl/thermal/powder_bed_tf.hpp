#pragma once
// Transfer function of the 1D SLS powder bed of seed 002 (de Carvalho et al., 2018):
//   rho Cp T_t = k0 T_zz on z in [0, l],  k0 T_z(l) = U (flux in, W/m^2),  T_z(0) = 0,
//   y = T(l).  With a^2 = k0/(rho Cp) (a in m/s^0.5, the square root of the diffusivity):
//   G(s) = a cosh(sqrt(s) l/a) / (k0 sqrt(s) sinh(sqrt(s) l/a))             (paper eq. 7)
//        = r0/s + sum_k r_k/(s - p_k),   r0 = a^2/(k0 l),  r_k = 2 a^2/(k0 l),
//          p_k = -(k pi a/l)^2                                          (corrected eq. 10)
// Units: s in 1/s, G in K m^2/W (kelvin per W/m^2); residues in K m^2/(W s).
// See docs/thermal.md for the derivation and where the printed equations differ.
#include <complex>
#include <vector>

namespace amctl::thermal {

/// Thermal properties of a powder (defaults: polyamide 12, table 1 of seed 002).
struct PowderMaterial {
  double density_kg_m3 = 1010.0;
  double specific_heat_j_kgk = 1928.0;
  double conductivity_w_mk = 0.28;

  /// Throws amctl::Error naming the first non-positive or non-finite property.
  void validate() const;
  /// Thermal diffusivity a^2 = k0/(rho Cp) in m^2/s.
  [[nodiscard]] double diffusivity_m2_s() const {
    return conductivity_w_mk / (density_kg_m3 * specific_heat_j_kgk);
  }
  /// Volumetric heat capacity rho Cp in J/(m^3 K).
  [[nodiscard]] double volumetric_heat_j_m3k() const { return density_kg_m3 * specific_heat_j_kgk; }
};

/// One point of a Bode plot.
struct BodePoint {
  double omega_rad_s = 0.0;
  double magnitude = 0.0;  ///< |G(j omega)| in K m^2/W
  double magnitude_db = 0.0;
  double phase_deg = 0.0;  ///< unwrapped along the grid
};

/// The exact irrational G(s) of a powder column of depth `length_m`, and its modal pieces.
class PowderBedTf {
 public:
  /// Throws amctl::Error for bad material constants or a non-positive length.
  PowderBedTf(const PowderMaterial& material, double length_m);

  [[nodiscard]] const PowderMaterial& material() const { return material_; }
  [[nodiscard]] double length_m() const { return length_m_; }

  /// Exact G(s) (eq. 7) in a form that neither overflows nor cancels: coth evaluated from
  /// exp(-2w) with Re w >= 0, a series near w = 0. Returns inf at s = 0 (the integrator).
  [[nodiscard]] std::complex<double> eval(std::complex<double> s) const;
  /// G(s) - r0/s (the stable, regular part), finite at s = 0 where it equals l/(3 k0); a
  /// series for coth(w) - 1/w avoids the cancellation of the two large terms near s = 0.
  [[nodiscard]] std::complex<double> eval_regular(std::complex<double> s) const;

  /// Pole k: p_0 = 0, p_k = -(k pi a / l)^2 (eq. 8).
  [[nodiscard]] double pole(int k) const;
  /// Zero k >= 0: z_k = -((k + 1/2) pi a / l)^2.
  [[nodiscard]] double zero(int k) const;
  /// Residue at pole k: a^2/(k0 l) for k = 0, 2 a^2/(k0 l) for k >= 1.
  [[nodiscard]] double residue(int k) const;

  /// Truncated modal expansion G_N(s) = r0/s + sum_{k=1..N} r_k/(s - p_k) (eq. 12, corrected).
  [[nodiscard]] std::complex<double> eval_modal(std::complex<double> s, int modes) const;
  /// The tail sum_{k>N} r_k/(-p_k) = (G - G_N)(0) = 2 l/(k0 pi^2) sum_{k>N} 1/k^2. Every tail
  /// term r/(s - p) with r > 0, p < 0 peaks in modulus at s = 0 over the closed right half
  /// plane, all with phase 0 there, so this is also ||G - G_N||_inf exactly (the a-priori
  /// bound is attained).
  [[nodiscard]] double modal_tail_bound(int modes) const;
  /// Bound (13) exactly as printed in the paper, 2 l/(k0 (pi a)^2) sum_{k>N} 1/k^2 (it carries a
  /// spurious 1/a^2 and is not dimensionally a transfer function value). For comparison only.
  [[nodiscard]] double printed_bound_13(int modes) const;

  /// Bode data on a log grid [w_min, w_max] with `points` samples; modes < 0 means exact G.
  [[nodiscard]] std::vector<BodePoint> bode(double w_min, double w_max, int points,
                                            int modes = -1) const;

 private:
  PowderMaterial material_;
  double length_m_;
  double a_;   // sqrt(diffusivity), m/s^0.5
  double x1_;  // l/a, s^0.5
};

/// sum_{k=N+1}^inf 1/k^2 = pi^2/6 - sum_{k<=N} 1/k^2, computed stably (Euler-Maclaurin tail).
[[nodiscard]] double basel_tail(int n);

}  // namespace amctl::thermal
