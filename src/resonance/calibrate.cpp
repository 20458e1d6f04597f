// Klipper's shaper fit and recommendation (shaper_calibrate.py: fit_shaper,
// _estimate_remaining_vibrations, _estimate_shaper, find_best_shaper), written anew.
#include "amctl/resonance/calibrate.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/output.hpp"
#include "amctl/shaping/measures.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::resonance {
namespace {

/// Klipper's minimum test frequency per shaper (shaper_defs.INPUT_SHAPERS).
double klipper_min_freq_hz(const std::string& name) {
  if (name == "zv") return 21.0;
  if (name == "mzv") return 23.0;
  if (name == "zvd") return 29.0;
  if (name == "ei") return 29.0;
  if (name == "2hump_ei") return 39.0;
  if (name == "3hump_ei") return 48.0;
  throw Error(fmt::format("shaper '{}' is not one Klipper calibrates; valid: zv, mzv, zvd, ei, "
                          "2hump_ei, 3hump_ei",
                          name));
}

/// numpy.arange(start, stop, step) for doubles: ceil((stop - start) / step) values
/// start + i * delta with delta = (start + step) - start.
std::vector<double> numpy_arange(double start, double stop, double step) {
  const double len = std::ceil((stop - start) / step);
  if (!(len > 0)) return {};
  const auto n = static_cast<std::size_t>(len);
  std::vector<double> v(n);
  const double delta = (start + step) - start;
  v[0] = start;
  for (std::size_t i = 1; i < n; ++i) v[i] = start + static_cast<double>(i) * delta;
  return v;
}

/// The PSD restricted to f <= max_freq, with what the vibration estimate needs of it.
struct FitPsd {
  std::vector<double> freq_hz;
  std::vector<double> psd;
  double threshold = 0.0;
  double all_vibrations = 0.0;
  /// Bins with psd > threshold: only they can leave vibrations (a shaper of non-negative
  /// amplitudes has a response <= 1, so vals * psd - threshold <= 0 elsewhere).
  std::vector<std::size_t> active;
};

FitPsd prepare(const PsdTable& t, double max_freq) {
  FitPsd f;
  for (std::size_t k = 0; k < t.freq_hz.size(); ++k) {
    if (t.freq_hz[k] <= max_freq) {
      f.freq_hz.push_back(t.freq_hz[k]);
      f.psd.push_back(t.psd_xyz[k]);
    }
  }
  if (f.psd.empty()) throw Error(fmt::format("the PSD has no bin at or below {} Hz", max_freq));
  f.threshold = *std::max_element(f.psd.begin(), f.psd.end()) / kKlipperVibrationReduction;
  for (std::size_t k = 0; k < f.psd.size(); ++k) {
    const double d = f.psd[k] - f.threshold;
    if (d > 0) {
      f.all_vibrations += d;
      f.active.push_back(k);
    }
  }
  return f;
}

/// Klipper's _estimate_shaper at one frequency: |sum A_i e^{-zeta w (T_n - T_i)}
/// e^{j w_d T_i}| / sum A.
double shaper_response(const shaping::Shaper& s, double inv_d, double zeta, double freq_hz) {
  const double omega = 2.0 * std::numbers::pi * freq_hz;
  const double damping = zeta * omega;
  const double omega_d = omega * std::sqrt(1.0 - zeta * zeta);
  const double t_last = s.times_s.back();
  double ssum = 0.0;
  double csum = 0.0;
  for (std::size_t i = 0; i < s.amplitudes.size(); ++i) {
    const double w = s.amplitudes[i] * std::exp(-damping * (t_last - s.times_s[i]));
    ssum += w * std::sin(omega_d * s.times_s[i]);
    csum += w * std::cos(omega_d * s.times_s[i]);
  }
  return std::sqrt(ssum * ssum + csum * csum) * inv_d;
}

/// The remaining vibrations pessimised over the test damping ratios.
double shaper_vibrations_one(const shaping::Shaper& s, const FitPsd& psd,
                             const std::vector<double>& test_damping_ratios) {
  const double inv_d = 1.0 / s.amplitude_sum();
  const bool non_negative =
      std::all_of(s.amplitudes.begin(), s.amplitudes.end(), [](double a) { return a >= 0; });
  double worst = 0.0;
  for (const double dr : test_damping_ratios) {
    double remaining = 0.0;
    if (non_negative) {
      for (const std::size_t k : psd.active) {
        remaining += std::max(shaper_response(s, inv_d, dr, psd.freq_hz[k]) * psd.psd[k] -
                                  psd.threshold, 0.0);
      }
    } else {
      for (std::size_t k = 0; k < psd.psd.size(); ++k) {
        remaining += std::max(shaper_response(s, inv_d, dr, psd.freq_hz[k]) * psd.psd[k] -
                                  psd.threshold, 0.0);
      }
    }
    const double v = remaining / psd.all_vibrations;
    if (v > worst) worst = v;
  }
  return worst;
}

/// ... and over every record (Klipper: the worst of all, as it keeps the records apart).
double shaper_vibrations(const shaping::Shaper& s, const std::vector<FitPsd>& psds,
                         const std::vector<double>& test_damping_ratios) {
  double worst = 0.0;
  for (const FitPsd& psd : psds) worst = std::max(worst, shaper_vibrations_one(s, psd, test_damping_ratios));
  return worst;
}

/// fit_shaper: returns the selected fit first, then every tested frequency (highest first).
std::vector<ShaperFit> fit_shaper(const std::string& name, const std::vector<FitPsd>& psd,
                                  const KlipperOptions& o) {
  const double freq_end = kKlipperMaxShaperFreqHz;
  const double freq_start = std::min(klipper_min_freq_hz(name), freq_end - 1e-7);
  const std::vector<double> test_freqs = numpy_arange(freq_start, freq_end, kKlipperShaperFreqStepHz);
  std::vector<ShaperFit> results;
  results.reserve(test_freqs.size());
  std::optional<std::size_t> best;
  for (auto it = test_freqs.rbegin(); it != test_freqs.rend(); ++it) {
    const shaping::Shaper s = shaping::make_shaper(name, *it, o.damping_ratio);
    const double smoothing = shaping::smoothing_mm(s, shaping::kKlipperSmoothingAccelMmS2, o.scv_mm_s);
    if (o.max_smoothing_mm && smoothing > *o.max_smoothing_mm && best) {
      std::vector<ShaperFit> out{results[*best]};
      out.insert(out.end(), results.begin(), results.end());
      return out;
    }
    ShaperFit fit;
    fit.name = name;
    fit.freq_hz = *it;
    fit.smoothing_mm = smoothing;
    fit.max_accel_mm_s2 = shaping::max_accel_mm_s2(s, o.scv_mm_s);
    fit.vibrations = shaper_vibrations(s, psd, o.test_damping_ratios);
    const double v = fit.vibrations;
    fit.score = smoothing * (std::pow(v, 1.5) + v * 0.2 + 0.01);
    results.push_back(fit);
    if (!best || results[*best].vibrations > fit.vibrations) best = results.size() - 1;
  }
  if (!best) throw Error(fmt::format("shaper '{}': no test frequency below {} Hz", name, freq_end));
  const ShaperFit& b = results[*best];
  std::size_t selected = *best;
  for (std::size_t i = results.size(); i-- > 0;) {
    const ShaperFit& r = results[i];
    if (r.vibrations < b.vibrations * 1.1 + 0.0005 &&
        (r.score < results[selected].score ||
         (o.max_vibrations && b.vibrations > *o.max_vibrations))) {
      selected = i;
    }
  }
  std::vector<ShaperFit> out{results[selected]};
  out.insert(out.end(), results.begin(), results.end());
  return out;
}

double peak_freq(const PsdTable& t, const std::vector<double>& v, double max_freq) {
  double best = -1.0;
  double at = 0.0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    if (t.freq_hz[k] <= max_freq && v[k] > best) {
      best = v[k];
      at = t.freq_hz[k];
    }
  }
  return at;
}

}  // namespace

KlipperCalibration klipper_calibrate(const PsdTable& normalized_psd, const KlipperOptions& o) {
  return klipper_calibrate(std::vector<PsdTable>{normalized_psd}, o);
}

KlipperCalibration klipper_calibrate(const std::vector<PsdTable>& normalized_psds,
                                     const KlipperOptions& o) {
  if (normalized_psds.empty()) throw Error("klipper_calibrate: no PSD");
  for (const PsdTable& t : normalized_psds) {
    if (!t.normalized) {
      throw Error("klipper_calibrate: the PSD is not normalised (normalize_to_frequencies first)");
    }
  }
  require_positive("scv_mm_s", o.scv_mm_s);
  shaping::require_damping_ratio("damping_ratio", o.damping_ratio);
  if (o.test_damping_ratios.empty()) throw Error("test_damping_ratios must not be empty");
  for (const double dr : o.test_damping_ratios) shaping::require_damping_ratio("test_damping_ratios", dr);
  if (o.shapers.empty()) throw Error("shapers must not be empty");
  require_positive("max_freq_hz", o.max_freq_hz);

  // fit_shaper: max_freq = max(max_freq, highest test frequency) = max(max_freq, ~149.8).
  std::vector<FitPsd> psd;
  for (const PsdTable& t : normalized_psds) {
    psd.push_back(prepare(t, std::max(o.max_freq_hz, kKlipperMaxShaperFreqHz - kKlipperShaperFreqStepHz)));
  }
  KlipperCalibration out;
  std::optional<ShaperFit> best;
  for (const std::string& name : o.shapers) {
    const std::vector<ShaperFit> fits = fit_shaper(name, psd, o);
    ShaperFit shaper = fits.front();
    if (!best || shaper.score * 1.2 < best->score ||
        (shaper.score * 1.05 < best->score && shaper.smoothing_mm * 1.1 < best->smoothing_mm) ||
        (o.max_vibrations && best->vibrations > *o.max_vibrations &&
         shaper.vibrations < best->vibrations)) {
      best = shaper;
    }
    // results[::-1]: from the lowest tested frequency up.
    for (std::size_t i = fits.size(); i-- > 1;) {
      const ShaperFit& s = fits[i];
      if (s.vibrations < best->vibrations && s.smoothing_mm < best->smoothing_mm) {
        best = s;
        shaper = s;
      }
    }
    out.shapers.push_back(shaper);
  }
  if (best->name == "zv") {
    for (const ShaperFit& s : out.shapers) {
      if (s.name != "zv" && s.vibrations * 1.1 < best->vibrations) {
        best = s;
        break;
      }
    }
  }
  out.recommended = *best;
  return out;
}

namespace {

void check_axis(char axis) {
  if (axis != 'x' && axis != 'y' && axis != 0) {
    throw Error(fmt::format("axis must be x or y, got '{}'", axis));
  }
}

/// The normalised PSDs a file adds to a fit: its record's, or each of its PSD columns.
std::vector<PsdTable> fit_tables(const AccelFile& file, const CalibrationReport& r) {
  std::vector<PsdTable> out{r.psd};
  for (PsdTable t : file.more_psd) {
    normalize_to_frequencies(t);
    out.push_back(std::move(t));
  }
  return out;
}

std::vector<std::string> table_names(const AccelFile& file, const std::string& source) {
  if (file.more_psd.empty()) return {source};
  std::vector<std::string> out{file.psd.name};
  for (const PsdTable& t : file.more_psd) out.push_back(t.name);
  return out;
}

}  // namespace

CalibrationReport calibrate(const AccelFile& file, const std::string& source,
                            const CalibrateOptions& options) {
  check_axis(options.axis);
  CalibrationReport r;
  r.source = source;
  r.format = file.format;
  r.axis = options.axis;
  if (file.format == RecordFormat::klipper_psd) {
    r.psd = file.psd;
    if (!file.psd.normalized) {
      WelchPsd raw;
      raw.table = file.psd;
      r.welch = raw;
    }
  } else {
    r.quality = assess_record(file.record);
    // The spectrum of a record ends at half its sample rate: a shaper recommendation needs it
    // up to max_freq_hz (Klipper's 200 Hz). A 10 Hz record has nothing to say about a 40 Hz
    // resonance, however confident the fit on what it has would look.
    const double nyquist = 0.5 * r.quality->sample_rate_hz;
    if (!(nyquist >= options.klipper.max_freq_hz)) {
      throw Error(SourceLocation{source, 0, 0},
                  fmt::format("sampled at {:.4g} Hz, its spectrum ends at {:.4g} Hz; a shaper recommendation "
                              "needs it up to {:g} Hz: expected a record sampled at {:g} Hz or more "
                              "(Klipper's ADXL345 samples at 3200 Hz)",
                              r.quality->sample_rate_hz, nyquist, options.klipper.max_freq_hz,
                              2.0 * options.klipper.max_freq_hz));
    }
    r.welch = klipper_psd(file.record);
    r.psd = r.welch->table;
  }
  if (options.sweep) {
    if (file.format == RecordFormat::klipper_psd) {
      throw Error(fmt::format("{}: --sweep needs a time record, not a PSD", source));
    }
    r.identification = identify_sweep(file.record, options.axis, *options.sweep, options.modes);
  }
  normalize_to_frequencies(r.psd);
  {
    // A record without vibration on the axis asked about (a constant column: the sensor was
    // on another axis, or not read) has a spectrum of zeros, and every shaper fits it
    // "perfectly": that is no recommendation.
    const std::vector<double>& psd = options.axis == 'x' ? r.psd.psd_x : options.axis == 'y' ? r.psd.psd_y
                                                                                            : r.psd.psd_xyz;
    double top = 0.0;
    for (std::size_t i = 0; i < psd.size() && i < r.psd.freq_hz.size(); ++i) {
      if (r.psd.freq_hz[i] <= options.klipper.max_freq_hz) top = std::max(top, psd[i]);
    }
    if (!psd.empty() && !(top > 0.0)) {
      throw Error(SourceLocation{source, 0, 0},
                  fmt::format("found no vibration on {} (its spectrum is 0 up to {:g} Hz: every sample the "
                              "same), expected the record of a resonance test",
                              options.axis == 'x' ? "x" : options.axis == 'y' ? "y" : "any axis",
                              options.klipper.max_freq_hz));
    }
  }
  r.sources = table_names(file, source);
  r.klipper = klipper_calibrate(fit_tables(file, r), options.klipper);
  const double fmax = options.klipper.max_freq_hz;
  const std::vector<double>& axis_psd = options.axis == 'x' ? r.psd.psd_x : r.psd.psd_y;
  r.peak_axis_hz = options.axis != 0 && !axis_psd.empty() ? peak_freq(r.psd, axis_psd, fmax)
                                                           : std::numeric_limits<double>::quiet_NaN();
  r.peak_xyz_hz = peak_freq(r.psd, r.psd.psd_xyz, fmax);
  if (options.sweep || file.format == RecordFormat::corpus) {
    ExcitationCaveat c;
    const std::string rule =
        "Klipper's rule is tuned on Klipper's own test, pulses of accel_per_hz * f (60 mm/s^2 per Hz), "
        "whose excitation grows as f^2 in the PSD";
    if (options.sweep) {
      c.excitation = "constant_amplitude_sweep";
      c.why = fmt::format(
          "{}; this record is a constant-amplitude sweep ({:g} mm/s^2, {:g} to {:g} Hz), flat in f, "
          "so against Klipper's test it weights the low frequencies up by 1/f^2 (16 times at a quarter "
          "of a frequency), where the measured acceleration is mostly the commanded motion itself: the "
          "rule then favours low shaper frequencies",
          rule, options.sweep->accel_mm_s2, options.sweep->f0_hz, options.sweep->f1_hz);
      if (r.welch) {
        // The excitation ratio (accel_per_hz f / A)^2 up to a constant, which the rule ignores.
        PsdTable w = r.welch->table;
        for (std::size_t i = 0; i < w.freq_hz.size(); ++i) {
          const double f2 = w.freq_hz[i] * w.freq_hz[i];
          w.psd_x[i] *= f2;
          w.psd_y[i] *= f2;
          w.psd_z[i] *= f2;
          w.psd_xyz[i] *= f2;
        }
        w.normalized = false;
        normalize_to_frequencies(w);
        c.reweighted = klipper_calibrate(w, options.klipper);
      }
    } else {
      c.excitation = "unknown";
      c.why = fmt::format(
          "{}; this record is not in Klipper's format ({}), so how it was excited is not known: if it "
          "was a constant-amplitude sweep the rule is biased toward low shaper frequencies. Give the "
          "sweep (--sweep F0,F1,RATE,ACCEL): the frequency response divides the excitation out "
          "(modal fit), the rule is rerun on the PSD reweighted to Klipper's excitation, and "
          "--recommend picks the shaper by simulating the fitted model",
          rule, to_string(file.format));
    }
    r.caveat = std::move(c);
  }
  return r;
}

CalibrationReport calibrate_file(const std::string& path, const CalibrateOptions& options) {
  check_axis(options.axis);
  return calibrate(read_accel_file(path), path == "-" ? "<stdin>" : path, options);
}

CalibrationReport calibrate_files(const std::vector<std::string>& paths,
                                  const CalibrateOptions& options) {
  if (paths.empty()) throw Error("resonance calibrate: no file");
  if (paths.size() == 1) return calibrate_file(paths.front(), options);
  if (options.sweep) {
    throw Error("--sweep takes one record: found several files, expected one (the sweep is "
                "fitted to one record's response)");
  }
  check_axis(options.axis);
  std::size_t stdin_uses = 0;
  for (const std::string& p : paths) stdin_uses += p == "-" ? 1 : 0;
  if (stdin_uses > 1) throw Error("found '-' (standard input) twice, expected it once");
  // The first file makes the report; every file's tables join the fit.
  const AccelFile first = read_accel_file(paths.front());
  CalibrationReport r = calibrate(first, paths.front() == "-" ? "<stdin>" : paths.front(), options);
  std::vector<PsdTable> tables = fit_tables(first, r);
  for (std::size_t i = 1; i < paths.size(); ++i) {
    const AccelFile f = read_accel_file(paths[i]);
    PsdTable t = f.format == RecordFormat::klipper_psd ? f.psd : klipper_psd(f.record).table;
    normalize_to_frequencies(t);
    CalibrationReport one;
    one.psd = t;
    for (PsdTable& x : fit_tables(f, one)) tables.push_back(std::move(x));
    for (std::string& n : table_names(f, paths[i] == "-" ? "<stdin>" : paths[i])) r.sources.push_back(std::move(n));
  }
  r.klipper = klipper_calibrate(tables, options.klipper);
  return r;
}

namespace {

Json clipping_json(const AxisClipping& c) {
  return Json{{"min_mm_s2", json_number(c.min_mm_s2)},
              {"max_mm_s2", json_number(c.max_mm_s2)},
              {"runs", c.runs},
              {"samples", c.samples}};
}

Json fit_json(const ShaperFit& f) {
  return Json{{"name", f.name},
              {"freq_hz", json_number(f.freq_hz)},
              {"vibrations", json_number(f.vibrations)},
              {"smoothing", json_number(f.smoothing_mm)},
              {"score", json_number(f.score)},
              {"max_accel_mm_s2", json_number(f.max_accel_mm_s2)}};
}

}  // namespace

Json to_json(const CalibrationReport& r) {
  Json j;
  j["source"] = r.source;
  j["sources"] = r.sources.empty() ? Json::array({r.source}) : Json(r.sources);
  j["format"] = std::string(to_string(r.format));
  j["axis"] = r.axis != 0 ? Json(std::string(1, r.axis)) : Json(nullptr);
  if (r.quality) {
    const RecordQuality& q = *r.quality;
    j["sample_rate_hz"] = json_number(q.sample_rate_hz);
    j["jitter"] = json_number(q.jitter);
    j["gaps"] = Json{{"count", q.gaps},
                     {"largest_s", json_number(q.largest_gap_s)},
                     {"missing_s", json_number(q.missing_s)}};
    const std::size_t clipped = q.clip_x.samples + q.clip_y.samples + q.clip_z.samples;
    j["clipping"] = Json{{"samples", clipped},
                         {"x", clipping_json(q.clip_x)},
                         {"y", clipping_json(q.clip_y)},
                         {"z", clipping_json(q.clip_z)}};
    j["record"] = Json{{"samples", q.samples},
                       {"duration_s", json_number(q.duration_s)},
                       {"median_interval_s", json_number(q.median_interval_s)},
                       {"mean_sample_rate_hz", json_number(q.mean_sample_rate_hz)},
                       {"max_interval_deviation", json_number(q.max_interval_deviation)}};
  } else {
    j["sample_rate_hz"] = nullptr;
    j["jitter"] = nullptr;
    j["gaps"] = nullptr;
    j["clipping"] = nullptr;
    j["record"] = nullptr;
  }
  Json psd;
  const std::size_t bins = r.psd.freq_hz.size();
  psd["bins"] = bins;
  psd["bin_hz"] = json_number(bins > 1 ? r.psd.freq_hz[1] - r.psd.freq_hz[0] : 0.0);
  psd["peak_axis_hz"] = json_number(r.peak_axis_hz);
  psd["peak_xyz_hz"] = json_number(r.peak_xyz_hz);
  if (r.welch && r.welch->segment_samples > 0) {
    psd["segment_samples"] = r.welch->segment_samples;
    psd["segments"] = r.welch->segments;
    psd["sample_rate_hz"] = json_number(r.welch->sample_rate_hz);
  }
  j["psd"] = psd;
  Json k;
  k["recommended"] = Json{{"name", r.klipper.recommended.name},
                          {"freq_hz", json_number(r.klipper.recommended.freq_hz)}};
  Json shapers = Json::array();
  for (const ShaperFit& f : r.klipper.shapers) shapers.push_back(fit_json(f));
  k["shapers"] = shapers;
  j["klipper"] = k;
  if (r.caveat) {
    Json c{{"excitation", r.caveat->excitation}, {"why", r.caveat->why}};
    c["klipper_rule_on_reweighted_psd"] =
        r.caveat->reweighted ? Json{{"name", r.caveat->reweighted->recommended.name},
                                    {"freq_hz", json_number(r.caveat->reweighted->recommended.freq_hz)}}
                             : Json(nullptr);
    j["excitation_caveat"] = std::move(c);
  }
  if (r.identification) {
    const SweepIdentification& id = *r.identification;
    const ModalFit& m = id.model;
    j["model"] = Json{{"kind", std::string(to_string(m.kind))},
                      {"natural_frequency_hz", json_number(m.natural_frequency_hz)},
                      {"natural_frequency_std_hz", json_number(m.natural_frequency_std_hz)},
                      {"damping_ratio", json_number(m.damping_ratio)},
                      {"damping_ratio_std", json_number(m.damping_ratio_std)},
                      {"gain", json_number(m.gain)},
                      {"gain_std", json_number(m.gain_std)},
                      {"rms_residual", json_number(m.rms_residual)},
                      {"bins_used", m.bins_used},
                      {"sweep_start_s", json_number(id.sweep_start_s)},
                      {"alignment_peak", json_number(id.alignment_peak)},
                      {"sweep_time_scale", json_number(id.time_scale)},
                      {"natural_frequency_sweep_clock_hz",
                       json_number(m.natural_frequency_hz / id.time_scale)},
                      {"segment_samples", id.segment_samples}};
    Json modes = Json::array();
    for (const ModeEstimate& e : m.modes) {
      modes.push_back(Json{{"natural_frequency_hz", json_number(e.natural_frequency_hz)},
                           {"natural_frequency_std_hz", json_number(e.natural_frequency_std_hz)},
                           {"damping_ratio", json_number(e.damping_ratio)},
                           {"damping_ratio_std", json_number(e.damping_ratio_std)},
                           {"gain", json_number(e.gain)},
                           {"gain_std", json_number(e.gain_std)},
                           {"peak_gain", json_number(e.peak_gain)}});
    }
    Json bic = Json::array();
    for (const double b : m.bic) bic.push_back(json_number(b));
    j["model"]["modes"] = modes;
    j["model"]["mode_count"] = m.modes.size();
    j["model"]["dominant_mode"] = m.dominant_mode;
    j["model"]["mode_selection"] = std::string(to_string(m.selection));
    j["model"]["bic"] = bic;
  }
  return j;
}

std::string to_text(const CalibrationReport& r) {
  std::string s = r.axis != 0 ? fmt::format("resonance calibration of {} ({}, axis {})\n", r.source,
                                            to_string(r.format), r.axis)
                              : fmt::format("resonance calibration of {} ({})\n", r.source,
                                            to_string(r.format));
  if (r.sources.size() > 1) {
    s += fmt::format("  records          {}: {} (the fit takes the worst of them at each "
                     "frequency, as calibrate_shaper.py with several files)\n",
                     r.sources.size(), fmt::join(r.sources, ", "));
  }
  if (r.quality) {
    const RecordQuality& q = *r.quality;
    s += fmt::format("  samples          {} over {:.3f} s\n", q.samples, q.duration_s);
    s += fmt::format("  sample rate      {:.2f} Hz (median interval; mean {:.2f} Hz)\n",
                     q.sample_rate_hz, q.mean_sample_rate_hz);
    s += fmt::format("  jitter           {:.3g} (RMS interval deviation / median)\n", q.jitter);
    s += fmt::format("  gaps             {} (largest {:.4g} s)\n", q.gaps, q.largest_gap_s);
    s += fmt::format("  clipping         x {} y {} z {} samples in runs at the extremes\n",
                     q.clip_x.samples, q.clip_y.samples, q.clip_z.samples);
  }
  if (r.welch && r.welch->segment_samples > 0) {
    s += fmt::format("  Welch PSD        {} segments of {} samples\n", r.welch->segments,
                     r.welch->segment_samples);
  }
  if (std::isfinite(r.peak_axis_hz)) {
    s += fmt::format("  PSD peak         {:.1f} Hz on {}, {:.1f} Hz on x+y+z\n", r.peak_axis_hz,
                     r.axis, r.peak_xyz_hz);
  } else {
    s += fmt::format("  PSD peak         {:.1f} Hz on x+y+z\n", r.peak_xyz_hz);
  }
  s += "\n  shaper      freq [Hz]  vibrations  smoothing [mm]  max accel [mm/s^2]\n";
  for (const ShaperFit& f : r.klipper.shapers) {
    s += fmt::format("  {:<10} {:>10.1f} {:>10.1f}% {:>15.3f} {:>19.0f}\n", f.name, f.freq_hz,
                     f.vibrations * 100.0, f.smoothing_mm, f.max_accel_mm_s2);
  }
  s += fmt::format("\n  recommended (Klipper's rule): {} at {:.1f} Hz\n", r.klipper.recommended.name,
                   r.klipper.recommended.freq_hz);
  if (r.identification) {
    const SweepIdentification& id = *r.identification;
    const ModalFit& m = id.model;
    s += fmt::format("\n  sweep found at    {:.4f} s (correlation {:.3f}, time scale {:.3f})\n",
                     id.sweep_start_s, id.alignment_peak, id.time_scale);
    s += fmt::format("  modal fit         f_n {:.3f} +- {:.3f} Hz, damping ratio {:.4f} +- {:.4f}, "
                     "gain {:.3f} +- {:.3f} ({} bins, {}, rms residual {:.3g})\n",
                     m.natural_frequency_hz, m.natural_frequency_std_hz, m.damping_ratio,
                     m.damping_ratio_std, m.gain, m.gain_std, m.bins_used,
                     to_string(m.kind), m.rms_residual);
    if (m.modes.size() > 1) {
      s += fmt::format("  modes             {} ({}); the figures above are the dominant mode's\n",
                       m.modes.size(), m.selection == ModeSelection::bic ? "chosen by BIC" : "asked");
      for (const ModeEstimate& e : m.modes) {
        s += fmt::format("    f_n {:.3f} +- {:.3f} Hz, damping ratio {:.4f} +- {:.4f}, gain {:.3f} +- {:.3f}, peak gain {:.3f}\n",
                         e.natural_frequency_hz, e.natural_frequency_std_hz, e.damping_ratio,
                         e.damping_ratio_std, e.gain, e.gain_std, e.peak_gain);
      }
    }
  }
  if (r.caveat) {
    s += r.caveat->reweighted ? "\n  caveat: Klipper's rule is biased on this record.\n"
                              : "\n  caveat: Klipper's rule may be biased on this record.\n";
    // Wrapped at ~92 columns for the terminal.
    std::string line = "   ";
    std::size_t pos = 0;
    const std::string& why = r.caveat->why;
    while (pos < why.size()) {
      std::size_t end = why.find(' ', pos);
      if (end == std::string::npos) end = why.size();
      const std::string word = why.substr(pos, end - pos);
      if (line.size() + 1 + word.size() > 92) {
        s += line + "\n";
        line = "   ";
      }
      line += " " + word;
      pos = end + 1;
    }
    s += line + ".\n";
    if (r.caveat->reweighted) {
      const ShaperFit& k = r.klipper.recommended;
      const ShaperFit& w = r.caveat->reweighted->recommended;
      s += fmt::format("    Klipper's rule on this record: {} at {:.1f} Hz (PSD peak {:.1f} Hz); on its PSD "
                       "reweighted to Klipper's\n    excitation (x f^2): {} at {:.1f} Hz",
                       k.name, k.freq_hz, r.peak_xyz_hz, w.name, w.freq_hz);
      if (r.identification) {
        s += fmt::format("; the modal fit: f_n {:.1f} Hz, damping ratio {:.3f}",
                         r.identification->model.natural_frequency_hz, r.identification->model.damping_ratio);
      }
      s += ".\n    --recommend (with --machine) picks the shaper by simulating the fitted model on a print.\n";
    }
  }
  return s;
}

void write_psd_csv(const CalibrationReport& r, const std::string& path, const OutputOptions& options) {
  if (!r.welch) {
    throw Error(fmt::format("{}: the input is a normalised PSD (with shapers); there is no raw "
                            "PSD to write",
                            path));
  }
  const PsdTable& t = r.welch->table;
  std::string buf = "freq,psd_x,psd_y,psd_z,psd_xyz\n";
  for (std::size_t k = 0; k < t.freq_hz.size(); ++k) {
    buf += fmt::format("{},{},{},{},{}\n", t.freq_hz[k], t.psd_x[k], t.psd_y[k], t.psd_z[k],
                       t.psd_xyz[k]);
  }
  write_output(path, buf, options);
}

void write_response_csv(const CalibrationReport& r, const std::string& path, const OutputOptions& options) {
  if (!r.identification) {
    throw Error(fmt::format("{}: no frequency response without --sweep", path));
  }
  const SweepIdentification& id = *r.identification;
  std::string buf = "freq_hz,gain,phase_rad,coherence,used,model_gain\n";
  for (const ResponseBin& b : id.response) {
    buf += fmt::format("{},{},{},{},{},{}\n", b.freq_hz, b.gain, b.phase_rad, b.coherence,
                       b.used ? 1 : 0, model_gain(id.model, b.freq_hz));
  }
  write_output(path, buf, options);
}

}  // namespace amctl::resonance
