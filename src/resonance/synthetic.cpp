#include "amctl/resonance/synthetic.hpp"

#include <array>
#include <cmath>
#include <numbers>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::resonance {

std::string synthetic_sweep_csv(const SyntheticSweep& s) {
  require_positive("natural_freq_hz", s.natural_freq_hz);
  require_positive("sample_rate_hz", s.sample_rate_hz);
  require_positive("rate_hz_s", s.rate_hz_s);
  require_positive("f0_hz", s.f0_hz);
  if (!(s.f1_hz > s.f0_hz)) throw Error("f1_hz must be above f0_hz");
  require_non_negative("lead_s", s.lead_s);
  if (!(s.damping_ratio >= 0 && s.damping_ratio < 1)) throw Error("damping_ratio must be in [0, 1)");
  for (const SyntheticMode& m : s.extra_modes) {
    require_positive("extra_modes.natural_freq_hz", m.natural_freq_hz);
    if (!(m.damping_ratio >= 0 && m.damping_ratio < 1)) throw Error("extra_modes.damping_ratio must be in [0, 1)");
    if (!std::isfinite(m.gain)) throw Error("extra_modes.gain must be finite");
  }
  const double w = 2.0 * std::numbers::pi * s.natural_freq_hz;
  const double sweep_s = (s.f1_hz - s.f0_hz) / s.rate_hz_s;
  const double total_s = sweep_s + 2.0 * s.lead_s;
  const auto n = static_cast<std::size_t>(std::floor(total_s * s.sample_rate_hz));
  auto base = [&](double t) {
    const double u = t - s.lead_s;
    if (u < 0 || u > sweep_s) return 0.0;
    const double amp = s.accel_per_hz_mm_s2 > 0 ? s.accel_per_hz_mm_s2 * (s.f0_hz + s.rate_hz_s * u)
                                                : s.accel_mm_s2;
    return amp * std::sin(2.0 * std::numbers::pi * (s.f0_hz * u + 0.5 * s.rate_hz_s * u * u));
  };
  // state: relative position and velocity
  std::array<double, 2> x{0.0, 0.0};
  std::vector<std::array<double, 2>> extra(s.extra_modes.size(), std::array<double, 2>{0.0, 0.0});
  auto deriv = [&](double t, const std::array<double, 2>& y) {
    return std::array<double, 2>{y[1], -base(t) - 2.0 * s.damping_ratio * w * y[1] - w * w * y[0]};
  };
  std::uint64_t state = s.seed * 6364136223846793005ULL + 1442695040888963407ULL;
  auto uniform = [&] {  // in [-1, 1)
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    return static_cast<double>(state >> 11) * 0x1.0p-52 - 1.0;
  };
  const double dt = 1.0 / s.sample_rate_hz;
  const int sub = 8;
  const double h = dt / sub;
  std::string out = "#time,accel_x,accel_y,accel_z\n";
  out.reserve(n * 40);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    double a = -(2.0 * s.damping_ratio * w * x[1] + w * w * x[0]);
    for (std::size_t e = 0; e < s.extra_modes.size(); ++e) {
      const SyntheticMode& m = s.extra_modes[e];
      const double we = 2.0 * std::numbers::pi * m.natural_freq_hz;
      a += -m.gain * (2.0 * m.damping_ratio * we * extra[e][1] + we * we * extra[e][0]);
    }
    const double main = a + s.noise_mm_s2 * uniform();
    const double cross = 0.05 * a + s.noise_mm_s2 * uniform();
    const double z = 9810.0 + s.noise_mm_s2 * uniform();
    const double ax = s.axis == 'y' ? cross : main;
    const double ay = s.axis == 'y' ? main : cross;
    out += fmt::format("{:.6f},{:.3f},{:.3f},{:.3f}\n", t, ax, ay, z);
    for (int k = 0; k < sub; ++k) {
      const double tk = t + k * h;
      const auto k1 = deriv(tk, x);
      const auto k2 = deriv(tk + h / 2, {x[0] + h / 2 * k1[0], x[1] + h / 2 * k1[1]});
      const auto k3 = deriv(tk + h / 2, {x[0] + h / 2 * k2[0], x[1] + h / 2 * k2[1]});
      const auto k4 = deriv(tk + h, {x[0] + h * k3[0], x[1] + h * k3[1]});
      x[0] += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
      x[1] += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
    }
    for (std::size_t e = 0; e < s.extra_modes.size(); ++e) {
      const SyntheticMode& m = s.extra_modes[e];
      const double we = 2.0 * std::numbers::pi * m.natural_freq_hz;
      auto de = [&](double tt, const std::array<double, 2>& y) {
        return std::array<double, 2>{y[1], -base(tt) - 2.0 * m.damping_ratio * we * y[1] - we * we * y[0]};
      };
      std::array<double, 2>& xe = extra[e];
      for (int k = 0; k < sub; ++k) {
        const double tk = t + k * h;
        const auto k1 = de(tk, xe);
        const auto k2 = de(tk + h / 2, {xe[0] + h / 2 * k1[0], xe[1] + h / 2 * k1[1]});
        const auto k3 = de(tk + h / 2, {xe[0] + h / 2 * k2[0], xe[1] + h / 2 * k2[1]});
        const auto k4 = de(tk + h, {xe[0] + h * k3[0], xe[1] + h * k3[1]});
        xe[0] += h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]);
        xe[1] += h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]);
      }
    }
  }
  return out;
}

}  // namespace amctl::resonance
