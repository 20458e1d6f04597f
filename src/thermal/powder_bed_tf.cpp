#include "amctl/thermal/powder_bed_tf.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "amctl/core/error.hpp"

namespace amctl::thermal {

using cd = std::complex<double>;
constexpr double kPi = std::numbers::pi;

void PowderMaterial::validate() const {
  require_positive("density_kg_m3 (rho)", density_kg_m3);
  require_positive("specific_heat_j_kgk (Cp)", specific_heat_j_kgk);
  require_positive("conductivity_w_mk (k0)", conductivity_w_mk);
}

double basel_tail(int n) {
  AMCTL_CHECK(n >= 0, "basel_tail needs n >= 0");
  // Exact terms N+1 .. N+K, then the Euler-Maclaurin tail from M = N+K:
  // sum_{k>M} 1/k^2 = 1/M - 1/(2M^2) + 1/(6M^3) - 1/(30M^5) + 1/(42M^7) - ...
  constexpr int kExplicit = 64;
  double sum = 0.0;
  for (int k = n + kExplicit; k > n; --k) sum += 1.0 / (double(k) * double(k));
  const double m = double(n + kExplicit);
  const double m2 = m * m;
  const double tail = 1.0 / m - 1.0 / (2.0 * m2) + 1.0 / (6.0 * m2 * m) -
                      1.0 / (30.0 * m2 * m2 * m) + 1.0 / (42.0 * m2 * m2 * m2 * m);
  return sum + tail;
}

PowderBedTf::PowderBedTf(const PowderMaterial& material, double length_m)
    : material_(material), length_m_(length_m) {
  material_.validate();
  require_positive("length_m (powder depth l)", length_m);
  a_ = std::sqrt(material_.diffusivity_m2_s());
  x1_ = length_m_ / a_;
}

namespace {
// coth(w) for Re w >= 0 without overflow: (1 + q)/(1 - q), q = exp(-2w), |q| <= 1.
// Near w = 0 the difference 1 - q cancels, so use the Laurent series there.
cd coth_right(cd w) {
  if (std::abs(w) < 1e-3) {
    const cd w2 = w * w;
    return 1.0 / w + w / 3.0 - w * w2 / 45.0 + 2.0 * w * w2 * w2 / 945.0;
  }
  const cd q = std::exp(-2.0 * w);
  return (1.0 + q) / (1.0 - q);
}
}  // namespace

cd PowderBedTf::eval(cd s) const {
  if (s == cd(0.0, 0.0)) return {std::numeric_limits<double>::infinity(), 0.0};
  const cd rs = std::sqrt(s);  // principal branch, Re >= 0; G is even in sqrt(s)
  const cd w = rs * x1_;
  return a_ / (material_.conductivity_w_mk * rs) * coth_right(w);
}

cd PowderBedTf::eval_regular(cd s) const {
  const double k0 = material_.conductivity_w_mk;
  if (s == cd(0.0, 0.0)) return {length_m_ / (3.0 * k0), 0.0};
  const cd rs = std::sqrt(s);
  const cd w = rs * x1_;
  cd f;  // coth(w) - 1/w
  if (std::abs(w) < 0.1) {
    const cd w2 = w * w;
    f = w * (1.0 / 3.0 + w2 * (-1.0 / 45.0 + w2 * (2.0 / 945.0 + w2 * (-1.0 / 4725.0 +
                                                                     w2 * 2.0 / 93555.0))));
  } else {
    f = coth_right(w) - 1.0 / w;
  }
  return a_ / (k0 * rs) * f;
}

double PowderBedTf::pole(int k) const {
  AMCTL_CHECK(k >= 0, "pole index must be >= 0");
  if (k == 0) return 0.0;
  const double c = double(k) * kPi * a_ / length_m_;
  return -c * c;
}

double PowderBedTf::zero(int k) const {
  AMCTL_CHECK(k >= 0, "zero index must be >= 0");
  const double c = (double(k) + 0.5) * kPi * a_ / length_m_;
  return -c * c;
}

double PowderBedTf::residue(int k) const {
  AMCTL_CHECK(k >= 0, "residue index must be >= 0");
  const double r0 = a_ * a_ / (material_.conductivity_w_mk * length_m_);
  return k == 0 ? r0 : 2.0 * r0;
}

cd PowderBedTf::eval_modal(cd s, int modes) const {
  AMCTL_CHECK(modes >= 0, "modes must be >= 0");
  cd sum = residue(0) / s;
  const double rk = residue(1);
  for (int k = 1; k <= modes; ++k) sum += rk / (s - pole(k));
  return sum;
}

double PowderBedTf::modal_tail_bound(int modes) const {
  return 2.0 * length_m_ / (material_.conductivity_w_mk * kPi * kPi) * basel_tail(modes);
}

double PowderBedTf::printed_bound_13(int modes) const {
  const double pa = kPi * a_;
  return 2.0 * length_m_ / (material_.conductivity_w_mk * pa * pa) * basel_tail(modes);
}

std::vector<BodePoint> PowderBedTf::bode(double w_min, double w_max, int points, int modes) const {
  require_positive("bode w_min", w_min);
  require_positive("bode w_max", w_max);
  if (!(w_max > w_min)) throw Error("bode: w_max must exceed w_min");
  if (points < 2) throw Error("bode: points must be >= 2, got " + std::to_string(points));
  std::vector<BodePoint> out;
  out.reserve(std::size_t(points));
  const double lmin = std::log10(w_min), lmax = std::log10(w_max);
  double prev_phase = 0.0;
  for (int i = 0; i < points; ++i) {
    const double w = std::pow(10.0, lmin + (lmax - lmin) * i / (points - 1));
    const cd s(0.0, w);
    const cd g = modes < 0 ? eval(s) : eval_modal(s, modes);
    BodePoint p;
    p.omega_rad_s = w;
    p.magnitude = std::abs(g);
    p.magnitude_db = 20.0 * std::log10(p.magnitude);
    double ph = std::arg(g) * 180.0 / kPi;
    if (i > 0) {
      while (ph - prev_phase > 180.0) ph -= 360.0;
      while (ph - prev_phase < -180.0) ph += 360.0;
    }
    p.phase_deg = ph;
    prev_phase = ph;
    out.push_back(p);
  }
  return out;
}

}  // namespace amctl::thermal
