// `amctl shaper show`: one shaper and Klipper's figures for it (report.hpp).
#include "amctl/shaping/report.hpp"

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::shaping {

ShaperReport shaper_report(const ShaperReportOptions& o) {
  ShaperReport r;
  r.shaper = make_shaper(o.type, o.freq_hz, o.damping_ratio);
  require_positive("smoothing_accel_mm_s2", o.smoothing_accel_mm_s2);
  require_non_negative("scv_mm_s", o.scv_mm_s);
  require_positive("target_smoothing_mm", o.target_smoothing_mm);
  r.smoothing_accel_mm_s2 = o.smoothing_accel_mm_s2;
  r.scv_mm_s = o.scv_mm_s;
  r.target_smoothing_mm = o.target_smoothing_mm;
  r.smoothing_mm = smoothing_mm(r.shaper, o.smoothing_accel_mm_s2, o.scv_mm_s);
  r.max_accel_mm_s2 = max_accel_mm_s2(r.shaper, o.scv_mm_s, o.target_smoothing_mm);
  const std::vector<double> design = {o.freq_hz};
  r.residual = vibration_curve(r.shaper, o.residual_at_hz.empty() ? design : o.residual_at_hz,
                               o.test_damping_ratio.value_or(o.damping_ratio));
  r.klipper_max_damping_ratio = klipper_max_damping_ratio(r.shaper.spec.type);
  return r;
}

Json to_json(const ShaperReport& r) {
  const auto numbers = [](const std::vector<double>& v) {
    Json a = Json::array();
    for (double x : v) a.push_back(json_number(x));
    return a;
  };
  Json j;
  j["type"] = to_string(r.shaper.spec);
  j["freq_hz"] = json_number(r.shaper.freq_hz);
  j["damping_ratio"] = json_number(r.shaper.damping_ratio);
  j["amplitudes"] = numbers(r.shaper.amplitudes);
  j["times_s"] = numbers(r.shaper.times_s);
  j["duration_s"] = json_number(r.shaper.duration_s());
  j["time_shift_s"] = json_number(r.shaper.time_shift_s());
  j["smoothing_mm"] = json_number(r.smoothing_mm);
  j["smoothing_accel_mm_s2"] = json_number(r.smoothing_accel_mm_s2);
  j["scv_mm_s"] = json_number(r.scv_mm_s);
  j["max_accel_mm_s2"] = json_number(r.max_accel_mm_s2);
  j["target_smoothing_mm"] = json_number(r.target_smoothing_mm);
  j["test_damping_ratio"] = json_number(r.residual.test_damping_ratio);
  j["residual_at_hz"] = numbers(r.residual.freqs_hz);
  j["residual_vibration"] = numbers(r.residual.remaining_fraction);
  j["klipper_max_damping_ratio"] =
      r.klipper_max_damping_ratio ? json_number(*r.klipper_max_damping_ratio) : Json(nullptr);
  return j;
}

std::string to_text(const ShaperReport& r) {
  const Shaper& s = r.shaper;
  std::string out = fmt::format("shaper {} at {:g} Hz, damping ratio {:g}\n", to_string(s.spec),
                                s.freq_hz, s.damping_ratio);
  out += fmt::format("  {:>3}  {:>14}  {:>14}  {:>12}\n", "i", "amplitude", "normalised", "time_ms");
  const std::vector<double> norm = s.normalized_amplitudes();
  for (std::size_t i = 0; i < s.amplitudes.size(); ++i) {
    out += fmt::format("  {:>3}  {:>14.10f}  {:>14.10f}  {:>12.6f}\n", i, s.amplitudes[i], norm[i],
                       s.times_s[i] * 1e3);
  }
  out += fmt::format("  duration            {:.6f} ms (centre {:.6f} ms)\n", s.duration_s() * 1e3,
                     s.time_shift_s() * 1e3);
  out += fmt::format("  smoothing           {:.6f} mm at accel {:g} mm/s^2, scv {:g} mm/s\n",
                     r.smoothing_mm, r.smoothing_accel_mm_s2, r.scv_mm_s);
  out += fmt::format("  max accel           {:.1f} mm/s^2 (smoothing {:g} mm at scv {:g} mm/s)\n",
                     r.max_accel_mm_s2, r.target_smoothing_mm, r.scv_mm_s);
  out += fmt::format("  residual vibration  test damping ratio {:g}\n", r.residual.test_damping_ratio);
  for (std::size_t i = 0; i < r.residual.freqs_hz.size(); ++i) {
    out += fmt::format("    {:>10g} Hz  {:10.6f} %\n", r.residual.freqs_hz[i],
                       r.residual.remaining_fraction[i] * 100.0);
  }
  if (r.klipper_max_damping_ratio && s.damping_ratio > *r.klipper_max_damping_ratio) {
    out += fmt::format("  note: Klipper accepts damping ratios up to {:g} for {}\n",
                       *r.klipper_max_damping_ratio, to_string(s.spec));
  }
  return out;
}

}  // namespace amctl::shaping
