// A shaper recommendation from a modal model with the shaped simulation (tuning/recommend.hpp).
#include "amctl/tuning/recommend.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <numbers>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/numerics/scalar_search.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/simulation/shaped_simulation.hpp"

namespace amctl::tuning {
namespace {

namespace dy = amctl::dynamics;

template <class... A>
void append(std::string& s, fmt::format_string<A...> f, A&&... a) {
  fmt::format_to(std::back_inserter(s), f, std::forward<A>(a)...);
}

double machine_accel(const machine::Machine& m) {
  return m.firmware == machine::Firmware::klipper ? m.max_accel_mm_s2 : m.print_accel_mm_s2;
}

void check_model(const ModalModel& model) {
  if (!std::isfinite(model.natural_frequency_hz) || model.natural_frequency_hz <= 0.0) {
    throw Error(fmt::format("--natural-frequency-hz: must be > 0, got {}", model.natural_frequency_hz));
  }
  if (!std::isfinite(model.damping_ratio) || model.damping_ratio < 0.0 || model.damping_ratio >= 1.0) {
    throw Error(fmt::format("--damping-ratio: must be in [0, 1), got {}", model.damping_ratio));
  }
}

void check_budget(double max_smoothing_mm) {
  if (!std::isfinite(max_smoothing_mm) || max_smoothing_mm <= 0.0) {
    throw Error(fmt::format("--max-smoothing-mm: must be > 0, got {}", max_smoothing_mm));
  }
}

// The planned test path and what every evaluation shares.
class Evaluator {
 public:
  Evaluator(const ModalModel& model, const machine::Machine& m, const RecommendOptions& o, double accel)
      : model_(dy::AxisModel::belt(model.natural_frequency_hz, model.damping_ratio)),
        opt_(o),
        accel_(accel) {
    const std::string text = ringing_tower_gcode(m);  // the source reads it in place
    plan::PlanSource src(std::string_view(text), "ringing-tower", m);
    plan::CollectSink sink;
    plan::Sink* sinks[] = {&sink};
    (void)plan::run_pipeline(src, sinks);
    moves_ = std::move(sink.moves);
    sim_.sample_rate_hz = o.sample_rate_hz;
    metrics_.keep_per_move = false;
    metrics_.worst_count = 1;
    dy::require_above_nyquist(o.sample_rate_hz, {&model_});
  }

  Candidate run(const std::string& type, double freq_hz) {
    std::optional<shaping::Shaper> shaper;
    Candidate c;
    c.name = type;
    c.freq_hz = freq_hz;
    if (!type.empty()) {
      if (freq_hz >= 0.5 * opt_.sample_rate_hz) {
        throw Error(fmt::format("shaper frequency {} Hz is at or above the simulation's Nyquist limit", freq_hz));
      }
      shaper = shaping::make_shaper(type, freq_hz, opt_.shaper_damping_ratio);
      c.smoothing_mm = shaping::smoothing_mm(*shaper, accel_, opt_.scv_mm_s);
      ++evaluations_;
    }
    simulation::ShapedStreamingSimulation s(model_, model_, sim_, metrics_,
                                            shaper, shaper);
    for (const plan::PlannedMove& mv : moves_) s.push(mv);
    const dy::QualityReport q = s.finish();
    c.contour_error_mm = q.max_contour_error_printing_mm;
    c.rms_contour_error_mm = q.rms_contour_error_printing_mm;
    if (!type.empty()) evaluated_.push_back(c);
    return c;
  }

  [[nodiscard]] std::size_t evaluations() const { return evaluations_; }
  [[nodiscard]] std::vector<Candidate> take_evaluated() { return std::move(evaluated_); }
  [[nodiscard]] const std::vector<plan::PlannedMove>& moves() const { return moves_; }

 private:
  dy::AxisModel model_;
  RecommendOptions opt_;
  double accel_;
  dy::SimulationOptions sim_;
  dy::MetricsOptions metrics_;
  std::vector<plan::PlannedMove> moves_;
  std::size_t evaluations_ = 0;
  std::vector<Candidate> evaluated_;
};

Json candidate_json(const Candidate& c) {
  return {{"name", c.name.empty() ? Json(nullptr) : Json(c.name)},
          {"freq_hz", c.name.empty() ? Json(nullptr) : json_number(c.freq_hz)},
          {"contour_error_mm", json_number(c.contour_error_mm)},
          {"rms_contour_error_mm", json_number(c.rms_contour_error_mm)},
          {"smoothing_mm", c.name.empty() ? Json(0.0) : json_number(c.smoothing_mm)}};
}

}  // namespace

std::string ringing_tower_gcode(const machine::Machine& m) {
  const double accel = machine_accel(m);
  constexpr double kSideMm = 40.0;
  constexpr double kX0 = 80.0, kY0 = 80.0;
  const double speeds_mm_s[] = {60.0, 120.0, 200.0};
  const double accel_fractions[] = {0.5, 1.0};
  std::string s = "; amctl ringing-tower test path\nG90\nM83\n";
  append(s, "G1 X{:.3f} Y{:.3f} Z0.200 F6000\n", kX0, kY0);
  // Extrusion per mm of a 0.45 x 0.2 mm line of 1.75 mm filament.
  const double e_per_mm = 0.45 * 0.2 / (std::numbers::pi * 0.875 * 0.875);
  double z = 0.2;
  for (double a_frac : accel_fractions) {
    for (double v : speeds_mm_s) {
      const double a = a_frac * accel;
      append(s, "M204 S{:.0f}\n", a);
      for (int loop = 0; loop < 2; ++loop) {
        const double corners[4][2] = {{kX0 + kSideMm, kY0}, {kX0 + kSideMm, kY0 + kSideMm}, {kX0, kY0 + kSideMm}, {kX0, kY0}};
        for (const auto& c : corners) {
          append(s, "G1 X{:.3f} Y{:.3f} E{:.5f} F{:.0f}\n", c[0], c[1], kSideMm * e_per_mm, v * 60.0);
        }
      }
      z += 0.2;
      append(s, "G1 Z{:.3f} F600\n", z);
    }
  }
  return s;
}

double min_frequency_for_smoothing(const std::string& type, double damping_ratio, double accel_mm_s2,
                                   double scv_mm_s, double max_smoothing_mm) {
  auto smooth = [&](double f) {
    return shaping::smoothing_mm(shaping::make_shaper(type, f, damping_ratio), accel_mm_s2, scv_mm_s);
  };
  // Smoothing falls as the frequency rises (the shaper gets shorter).
  double lo = 0.5, hi = 1.0;
  while (smooth(hi) > max_smoothing_mm) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e5) throw Error(fmt::format("--max-smoothing-mm {} cannot be met by {}", max_smoothing_mm, type));
  }
  if (smooth(lo) <= max_smoothing_mm) return lo;
  while (hi - lo > 1e-4) {
    const double mid = 0.5 * (lo + hi);
    (smooth(mid) > max_smoothing_mm ? lo : hi) = mid;
  }
  return hi;
}

Recommendation recommend(const ModalModel& model, const machine::Machine& machine, const RecommendOptions& o,
                         const std::optional<resonance::ShaperFit>& klipper_pick) {
  check_model(model);
  check_budget(o.max_smoothing_mm);
  if (o.grid_points < 3) throw Error(fmt::format("grid_points must be >= 3, got {}", o.grid_points));
  for (const std::string& t : o.shapers) (void)shaping::parse_shaper_spec(t);
  const auto t0 = std::chrono::steady_clock::now();
  Recommendation r;
  r.model = model;
  r.max_smoothing_mm = o.max_smoothing_mm;
  r.scv_mm_s = o.scv_mm_s;
  r.smoothing_accel_mm_s2 = o.smoothing_accel_mm_s2.value_or(machine_accel(machine));
  const double fn = model.natural_frequency_hz;
  // The budget's lower frequency limit per type; a type that the budget pushes above 10 f_n is
  // not searched (its shaper would be far off the mode).
  struct Range {
    std::string type;
    double lo_hz, hi_hz;
  };
  std::vector<Range> ranges;
  double top_hz = 0.0;
  for (const std::string& type : o.shapers) {
    const double f_min = min_frequency_for_smoothing(type, o.shaper_damping_ratio, r.smoothing_accel_mm_s2,
                                                     o.scv_mm_s, o.max_smoothing_mm);
    if (f_min > 10.0 * fn) {
      r.skipped.push_back(type);
      continue;
    }
    // Search from the budget's limit (or 0.5 f_n) up to 2.5 f_n (or 1.5 f_min if the budget
    // already forces the shaper above that).
    ranges.push_back({type, std::max(f_min, 0.5 * fn), std::max(2.5 * fn, 1.5 * f_min)});
    top_hz = std::max(top_hz, ranges.back().hi_hz);
  }
  if (ranges.empty()) {
    throw Error(fmt::format("--max-smoothing-mm {} forces every shaper above 10x the mode's {} Hz",
                            o.max_smoothing_mm, fn));
  }
  RecommendOptions opt = o;
  // The simulation must resolve the mode and every candidate frequency.
  opt.sample_rate_hz = std::max({o.sample_rate_hz, 30.0 * fn, 8.0 * top_hz});
  Evaluator ev(model, machine, opt, r.smoothing_accel_mm_s2);
  r.sample_rate_hz = opt.sample_rate_hz;
  r.path_moves = ev.moves().size();
  r.path_time_s = ev.moves().empty() ? 0.0 : ev.moves().back().end_time_s() - ev.moves().front().start_time_s;
  r.unshaped = ev.run("", 0.0);

  bool have_best = false;
  for (const Range& range : ranges) {
    const std::string& type = range.type;
    const double lo = range.lo_hz, hi = range.hi_hz;
    const std::size_t n = o.grid_points;
    std::vector<double> grid(n);
    std::vector<Candidate> cand;
    cand.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      grid[i] = lo * std::pow(hi / lo, static_cast<double>(i) / static_cast<double>(n - 1));
      cand.push_back(ev.run(type, grid[i]));
    }
    std::size_t k = 0;
    for (std::size_t i = 1; i < n; ++i) {
      if (cand[i].contour_error_mm < cand[k].contour_error_mm) k = i;
    }
    Candidate best = cand[k];
    // Golden section on [grid[k-1], grid[k+1]] (clamped to the admissible range); every
    // evaluated point competes for the best.
    numerics::GoldenSectionStop stop;
    stop.max_steps = o.golden_iterations;
    numerics::golden_section_minimize(
        [&](double f_hz) {
          Candidate c = ev.run(type, f_hz);
          const double e = c.contour_error_mm;
          if (e < best.contour_error_mm) best = std::move(c);
          return e;
        },
        grid[k == 0 ? 0 : k - 1], grid[std::min(k + 1, n - 1)], stop);
    r.per_type.push_back(best);
    if (!have_best || best.contour_error_mm < r.best.contour_error_mm) {
      r.best = best;
      have_best = true;
    }
  }
  r.evaluations = ev.evaluations();  // the search's, without Klipper's pick
  r.evaluated = ev.take_evaluated();
  if (klipper_pick) r.klipper = ev.run(klipper_pick->name, klipper_pick->freq_hz);
  r.compute_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

resonance::ShaperFit klipper_pick_for_model(const ModalModel& model, std::optional<double> max_smoothing_mm) {
  check_model(model);
  if (max_smoothing_mm) check_budget(*max_smoothing_mm);
  resonance::PsdTable psd;
  const double w = 2.0 * std::numbers::pi * model.natural_frequency_hz;
  const double z = model.damping_ratio;
  for (double f = 0.0; f <= resonance::kKlipperMaxFreqHz + 1e-9; f += 0.25) {
    const double om = 2.0 * std::numbers::pi * f;
    const double num = w * w * w * w + (2.0 * z * w * om) * (2.0 * z * w * om);
    const double den = (w * w - om * om) * (w * w - om * om) + (2.0 * z * w * om) * (2.0 * z * w * om);
    const double excitation = 60.0 * f;  // TEST_RESONANCES' accel per Hz
    const double p = num / den * excitation * excitation;
    psd.freq_hz.push_back(f);
    psd.psd_x.push_back(p);
    psd.psd_y.push_back(0.0);
    psd.psd_z.push_back(0.0);
    psd.psd_xyz.push_back(p);
  }
  resonance::normalize_to_frequencies(psd);
  resonance::KlipperOptions ko;
  ko.max_smoothing_mm = max_smoothing_mm;
  return resonance::klipper_calibrate(psd, ko).recommended;
}

Json to_json(const Recommendation& r) {
  Json per_type = Json::array();
  for (const Candidate& c : r.per_type) per_type.push_back(candidate_json(c));
  return {{"model", {{"natural_frequency_hz", json_number(r.model.natural_frequency_hz)},
                     {"damping_ratio", json_number(r.model.damping_ratio)}}},
          {"model_recommendation", candidate_json(r.best)},
          {"per_type", per_type},
          {"unshaped", candidate_json(r.unshaped)},
          {"klipper_pick", r.klipper ? candidate_json(*r.klipper) : Json(nullptr)},
          {"budget", {{"max_smoothing_mm", json_number(r.max_smoothing_mm)},
                      {"accel_mm_s2", json_number(r.smoothing_accel_mm_s2)},
                      {"scv_mm_s", json_number(r.scv_mm_s)}}},
          {"search", {{"evaluations", r.evaluations},
                      {"path_moves", r.path_moves},
                      {"path_time_s", json_number(r.path_time_s)},
                      {"sample_rate_hz", json_number(r.sample_rate_hz)},
                      {"skipped", r.skipped},
                      {"compute_time_s", json_number(r.compute_time_s)}}}};
}

std::string to_text(const Recommendation& r) {
  std::string s;
  append(s, "model: {:.2f} Hz, damping ratio {:.3f}\n", r.model.natural_frequency_hz, r.model.damping_ratio);
  append(s, "budget: smoothing <= {:.3f} mm at {:g} mm/s^2, scv {:g} mm/s\n", r.max_smoothing_mm,
         r.smoothing_accel_mm_s2, r.scv_mm_s);
  append(s, "{:<10} {:>8} {:>12} {:>12} {:>10}\n", "shaper", "freq_hz", "contour_mm", "rms_mm", "smooth_mm");
  auto row = [&s](const Candidate& c, const char* note) {
    append(s, "{:<10} {:>8} {:>12.4f} {:>12.4f} {:>10.4f}{}\n", c.name.empty() ? "none" : c.name,
           c.name.empty() ? std::string("-") : fmt::format("{:.2f}", c.freq_hz), c.contour_error_mm,
           c.rms_contour_error_mm, c.smoothing_mm, note);
  };
  row(r.unshaped, "");
  for (const Candidate& c : r.per_type) row(c, "");
  if (r.klipper) row(*r.klipper, "  (Klipper's pick)");
  for (const std::string& t : r.skipped) append(s, "{:<10} not searched: the budget needs it above 10x the mode\n", t);
  append(s, "recommended (simulated contour error): {} at {:.2f} Hz\n", r.best.name, r.best.freq_hz);
  append(s, "{} shaped simulations of a {:.1f} s test path ({} moves) in {:.2f} s\n", r.evaluations,
         r.path_time_s, r.path_moves, r.compute_time_s);
  return s;
}

}  // namespace amctl::tuning
