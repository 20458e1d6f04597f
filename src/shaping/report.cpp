// `amctl shaper show`: one shaper and Klipper's figures for it (report.hpp).
#include "amctl/shaping/report.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"

namespace amctl::shaping {

void check_report_options(const ShaperReportOptions& o, const std::function<std::string(std::string_view)>& name) {
  if (o.marlin_sample_rate_hz != 0.0 && !in_range(kSampleRateRange, o.marlin_sample_rate_hz)) {
    throw Error(fmt::format("{}: must be 0 (exact times) or {}, got {}", name("marlin_sample_rate_hz"),
                            describe(kSampleRateRange), o.marlin_sample_rate_hz));
  }
  const auto frequency = [&](std::string_view key, double f) {
    if (!in_range(kFrequencyRange, f)) throw Error(fmt::format("{}: must be {}, got {}", name(key), describe(kFrequencyRange), f));
  };
  const auto ratio = [&](std::string_view key, double z) {
    if (!(z >= 0.0 && z < 1.0)) throw Error(fmt::format("{}: must be a damping ratio in [0, 1), got {}", name(key), z));
  };
  frequency("freq_hz", o.freq_hz);
  ratio("damping_ratio", o.damping_ratio);
  if (o.test_damping_ratio) ratio("test_damping_ratio", *o.test_damping_ratio);
  for (const double f : o.residual_at_hz) frequency("residual_at_hz", f);
  ShaperSpec spec;
  try {  // the type under its parameter's name
    spec = o.firmware ? parse_shaper_spec(o.type, *o.firmware, o.marlin_sample_rate_hz) : parse_shaper_spec(o.type);
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", name("type"), e.what()));
  }
  try {  // Marlin's grid: the frequency's message names freq_hz
    (void)make_shaper(spec, o.freq_hz, o.damping_ratio);
  } catch (const Error& e) {
    const std::string_view m = e.what();
    if (m.rfind("freq_hz: ", 0) == 0) throw Error(fmt::format("{}: {}", name("freq_hz"), m.substr(9)));
    throw;
  }
}

ShaperReport shaper_report(const ShaperReportOptions& o) {
  ShaperReport r;
  const ShaperSpec spec = o.firmware ? parse_shaper_spec(o.type, *o.firmware, o.marlin_sample_rate_hz)
                                     : parse_shaper_spec(o.type);
  r.shaper = make_shaper(spec, o.freq_hz, o.damping_ratio);
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
  if (spec.firmware == Firmware::klipper) r.klipper_max_damping_ratio = klipper_max_damping_ratio(spec.type);
  r.residual_at_design = remaining_vibration(r.shaper, o.freq_hz, o.damping_ratio);
  if (spec.firmware == Firmware::marlin && spec.sample_rate_hz > 0.0) {
    ShaperSpec exact = spec;
    exact.sample_rate_hz = 0.0;
    r.residual_at_design_exact_times =
        remaining_vibration(make_shaper(exact, o.freq_hz, o.damping_ratio), o.freq_hz, o.damping_ratio);
  }
  // The other firmware's definition of the same name, where it has one that takes these
  // parameters (Klipper has no zvdd; Marlin no mzv(n, t); Klipper's humps fix v_tol).
  const Firmware other = spec.firmware == Firmware::marlin ? Firmware::klipper : Firmware::marlin;
  try {
    const ShaperSpec os = parse_shaper_spec(o.type, other, o.marlin_sample_rate_hz);
    FirmwareComparison c;
    c.shaper = make_shaper(os, o.freq_hz, o.damping_ratio);
    c.residual_at_design = remaining_vibration(c.shaper, o.freq_hz, o.damping_ratio);
    if (c.shaper.amplitudes.size() == r.shaper.amplitudes.size()) {
      const std::vector<double> a = r.shaper.normalized_amplitudes(), b = c.shaper.normalized_amplitudes();
      for (std::size_t i = 0; i < a.size(); ++i) {
        c.max_amplitude_difference = std::max(c.max_amplitude_difference, std::abs(a[i] - b[i]));
        c.max_time_difference_s =
            std::max(c.max_time_difference_s, std::abs(r.shaper.times_s[i] - c.shaper.times_s[i]));
      }
    } else {
      c.max_amplitude_difference = std::numeric_limits<double>::quiet_NaN();
      c.max_time_difference_s = std::numeric_limits<double>::quiet_NaN();
    }
    r.compared_with = c;
  } catch (const Error&) {
    // The other firmware lacks the type or its parameters: nothing to compare.
  }
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
  j["firmware"] = std::string(to_string(r.shaper.spec.firmware));
  j["sample_rate_hz"] = r.shaper.spec.sample_rate_hz > 0.0 ? json_number(r.shaper.spec.sample_rate_hz) : Json(nullptr);
  j["residual_at_design"] = json_number(r.residual_at_design);
  j["residual_at_design_exact_times"] =
      r.residual_at_design_exact_times ? json_number(*r.residual_at_design_exact_times) : Json(nullptr);
  if (r.compared_with) {
    const FirmwareComparison& c = *r.compared_with;
    j["compared_with"] = {{"firmware", std::string(to_string(c.shaper.spec.firmware))},
                          {"type", to_string(c.shaper.spec)},
                          {"amplitudes", numbers(c.shaper.amplitudes)},
                          {"times_s", numbers(c.shaper.times_s)},
                          {"residual_at_design", json_number(c.residual_at_design)},
                          {"max_amplitude_difference", json_number(c.max_amplitude_difference)},
                          {"max_time_difference_s", json_number(c.max_time_difference_s)},
                          {"same", c.same()}};
  } else {
    j["compared_with"] = nullptr;
  }
  return j;
}

std::string to_text(const ShaperReport& r) {
  const Shaper& s = r.shaper;
  std::string out = fmt::format("shaper {} at {:g} Hz, damping ratio {:g} ({}'s definition)\n",
                                to_string(s.spec), s.freq_hz, s.damping_ratio, to_string(s.spec.firmware));
  if (s.spec.sample_rate_hz > 0.0) {
    out += fmt::format("  times on Marlin's {:g} Hz trajectory grid (FTM_FS), as the firmware rounds them\n",
                       s.spec.sample_rate_hz);
  }
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
  out += fmt::format("  left at its own frequency {:.6f} % (mode of damping ratio {:g})\n",
                     r.residual_at_design * 100.0, s.damping_ratio);
  if (r.residual_at_design_exact_times) {
    out += fmt::format("    with the exact times of the definition {:.6f} %\n",
                       *r.residual_at_design_exact_times * 100.0);
  }
  if (r.compared_with) {
    const FirmwareComparison& c = *r.compared_with;
    const std::string who = fmt::format("{}'s {}", to_string(c.shaper.spec.firmware), to_string(c.shaper.spec));
    if (c.same()) {
      out += fmt::format("  {} is the same shaper\n", who);
    } else {
      out += fmt::format("  differs from {}: it leaves {:.6f} % at this frequency", who, c.residual_at_design * 100.0);
      if (std::isfinite(c.max_amplitude_difference)) {
        out += fmt::format(" (normalised amplitudes differ by up to {:.6f}, times by up to {:.6f} ms)",
                           c.max_amplitude_difference, c.max_time_difference_s * 1e3);
      } else {
        out += fmt::format(" ({} impulses instead of {})", c.shaper.amplitudes.size(), s.amplitudes.size());
      }
      out += "\n";
    }
  }
  if (r.klipper_max_damping_ratio && s.damping_ratio > *r.klipper_max_damping_ratio) {
    out += fmt::format("  note: Klipper accepts damping ratios up to {:g} for {}\n",
                       *r.klipper_max_damping_ratio, to_string(s.spec));
  }
  return out;
}

}  // namespace amctl::shaping
