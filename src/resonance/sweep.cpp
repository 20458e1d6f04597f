// Sweep alignment, frequency response and modal fit (sweep.hpp; docs/resonance.md §6).
#include "amctl/resonance/sweep.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <complex>
#include <limits>
#include <memory>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/numerics/fft.hpp"
#include "amctl/numerics/least_squares.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::resonance {
namespace {

using cd = std::complex<double>;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

std::size_t next_pow2(std::size_t n) {
  std::size_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

double sweep_phase(const SweepExcitation& s, double u) {
  return kTwoPi * (s.f0_hz * u + 0.5 * s.rate_hz_s * u * u);
}

/// |sum_n y[n + lag] e^{i phi_n}| / (||y[lag..lag+L)|| ||c||) for every lag in [0, N - L],
/// by FFT correlation of y with the cosine and sine chirps.
std::vector<double> chirp_correlation(const std::vector<double>& y, const SweepExcitation& s,
                                      double fs, double k_scale, std::size_t len) {
  const std::size_t n = y.size();
  const std::size_t p = next_pow2(n + len);
  numerics::RealFft fft(p);
  const std::size_t bins = fft.bins();
  const std::span<double> in = fft.signal();
  const std::span<cd> spec = fft.spectrum();
  std::copy(y.begin(), y.end(), in.begin());
  fft.forward();
  const std::vector<cd> out_y(spec.begin(), spec.end());

  const std::size_t lags = n - len + 1;
  std::vector<double> sum_sq(lags, 0.0);
  std::vector<double> mag2(lags, 0.0);
  for (int part = 0; part < 2; ++part) {
    std::fill(in.begin(), in.end(), 0.0);
    for (std::size_t i = 0; i < len; ++i) {
      const double ph = sweep_phase(s, k_scale * static_cast<double>(i) / fs);
      in[i] = part == 0 ? std::cos(ph) : std::sin(ph);
    }
    fft.forward();
    for (std::size_t k = 0; k < bins; ++k) spec[k] = out_y[k] * std::conj(spec[k]);
    fft.inverse();
    for (std::size_t l = 0; l < lags; ++l) {
      const double c = in[l] / static_cast<double>(p);
      mag2[l] += c * c;
    }
  }
  // Energy of y under the template at each lag (running sum).
  double e = 0.0;
  for (std::size_t i = 0; i < len; ++i) e += y[i] * y[i];
  for (std::size_t l = 0; l < lags; ++l) {
    sum_sq[l] = e;
    if (l + len < n) e += y[l + len] * y[l + len] - y[l] * y[l];
  }
  std::vector<double> corr(lags, 0.0);
  const double c_norm = std::sqrt(static_cast<double>(len) / 2.0);
  for (std::size_t l = 0; l < lags; ++l) {
    corr[l] = sum_sq[l] > 0 ? std::sqrt(mag2[l]) / (std::sqrt(sum_sq[l]) * c_norm) : 0.0;
  }
  return corr;
}

/// y with its amplitude spectrum flattened: each bin divided by the mean magnitude over
/// +-2 Hz around it. A resonance then weighs no more than the rest of the band in the
/// alignment (its group delay would otherwise pull the correlation peak late).
std::vector<double> whiten(const std::vector<double>& y, double fs) {
  const std::size_t p = next_pow2(y.size());
  numerics::RealFft fft(p);
  const std::size_t bins = fft.bins();
  const std::span<double> in = fft.signal();
  const std::span<cd> spec = fft.spectrum();
  std::copy(y.begin(), y.end(), in.begin());
  fft.forward();
  std::vector<double> mag(bins);
  for (std::size_t k = 0; k < bins; ++k) mag[k] = std::hypot(spec[k].real(), spec[k].imag());
  const auto half = static_cast<std::size_t>(std::max(1.0, 2.0 * static_cast<double>(p) / fs));
  std::vector<double> prefix(bins + 1, 0.0);
  for (std::size_t k = 0; k < bins; ++k) prefix[k + 1] = prefix[k] + mag[k];
  double floor = 0.0;
  for (const double m : mag) floor = std::max(floor, m);
  floor *= 1e-9;
  for (std::size_t k = 0; k < bins; ++k) {
    const std::size_t lo = k > half ? k - half : 0;
    const std::size_t hi = std::min(bins, k + half + 1);
    const double avg = (prefix[hi] - prefix[lo]) / static_cast<double>(hi - lo);
    const double scale = 1.0 / std::max(avg, floor);
    spec[k] *= scale;
  }
  fft.inverse();
  std::vector<double> out(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) out[i] = in[i] / static_cast<double>(p);
  return out;
}

/// The mode's gain at f for unit g: |2 zeta w s + w^2| / |s^2 + 2 zeta w s + w^2| (base
/// damped) or w^2 / |...| (ground damped), s = i 2 pi f.
double unit_gain(double fn, double zeta, double f, ModeKind kind) {
  const double w = kTwoPi * fn;
  const cd s(0.0, kTwoPi * f);
  const cd num = kind == ModeKind::base_damped ? 2.0 * zeta * w * s + w * w : cd(w * w, 0.0);
  return std::abs(num / (s * s + 2.0 * zeta * w * s + w * w));
}

/// Bins of the fit: frequency, ln |H1|, and the weight of the log-magnitude residual.
struct FitData {
  ModeKind kind = ModeKind::base_damped;
  std::vector<double> f;
  std::vector<double> log_gain;
  std::vector<double> sqrt_w;
};

/// Parameters: f_n, zeta, ln g.
using Params = std::array<double, 3>;

Eigen::VectorXd residuals(const FitData& d, const Params& p) {
  Eigen::VectorXd r(static_cast<Eigen::Index>(d.f.size()));
  for (std::size_t k = 0; k < d.f.size(); ++k) {
    r(static_cast<Eigen::Index>(k)) =
        (p[2] + std::log(unit_gain(p[0], p[1], d.f[k], d.kind)) - d.log_gain[k]) * d.sqrt_w[k];
  }
  return r;
}

Eigen::MatrixXd jacobian(const FitData& d, const Params& p) {
  Eigen::MatrixXd j(static_cast<Eigen::Index>(d.f.size()), 3);
  for (int c = 0; c < 3; ++c) {
    const double step = 1e-6 * std::max(std::abs(p[c]), 1e-3);
    Params a = p, b = p;
    a[c] += step;
    b[c] -= step;
    j.col(c) = (residuals(d, a) - residuals(d, b)) / (2.0 * step);
  }
  return j;
}

void clamp(Params& p) {
  p[0] = std::max(p[0], 0.1);
  p[1] = std::clamp(p[1], 1e-4, 0.95);
}

/// The cost with ln g at its closed-form least-squares value (which it sets in p).
double cost_with_best_gain(const FitData& d, Params& p) {
  double num = 0.0, den = 0.0;
  std::vector<double> lm(d.f.size());
  for (std::size_t k = 0; k < d.f.size(); ++k) {
    lm[k] = std::log(unit_gain(p[0], p[1], d.f[k], d.kind));
    const double w = d.sqrt_w[k] * d.sqrt_w[k];
    num += w * (d.log_gain[k] - lm[k]);
    den += w;
  }
  p[2] = num / den;
  double cost = 0.0;
  for (std::size_t k = 0; k < d.f.size(); ++k) {
    const double e = (p[2] + lm[k] - d.log_gain[k]) * d.sqrt_w[k];
    cost += e * e;
  }
  return cost;
}

/// A start: f_n over +-4 bins of the gain peak in quarter bins, zeta from 0.005 to 0.6
/// (log-spaced), g by least squares; the lowest cost. A sharp resonance has a basin narrower
/// than a bin, which Gauss-Newton from the peak bin alone can miss.
Params grid_start(const FitData& d, double f_peak, double df) {
  double best = std::numeric_limits<double>::infinity();
  Params out{f_peak, 0.05, 0.0};
  for (int i = -16; i <= 16; ++i) {
    for (int j = 0; j <= 32; ++j) {
      Params q{f_peak + 0.25 * df * i, 0.005 * std::pow(120.0, j / 32.0), 0.0};
      if (q[0] <= 0) continue;
      const double c = cost_with_best_gain(d, q);
      if (c < best) {
        best = c;
        out = q;
      }
    }
  }
  return out;
}

/// Levenberg-Marquardt (numerics::levenberg_marquardt, at most `max_iterations`) from p;
/// returns the cost sum r^2 and the accepted steps.
template <class P, class ResidualsOf, class JacobianOf, class ClampP>
std::pair<double, int> fit_lm(P& p, int max_iterations, const ResidualsOf& residuals_of,
                              const JacobianOf& jacobian_of, const ClampP& clamp_p) {
  numerics::LevenbergMarquardtOptions o;
  o.max_iterations = max_iterations;
  const auto r = numerics::levenberg_marquardt(p, residuals_of(p), residuals_of, jacobian_of, clamp_p, o);
  return {r.cost, r.accepted_steps};
}

/// Levenberg-Marquardt from p; returns the cost sum r^2 and the accepted steps.
std::pair<double, int> levenberg_marquardt(const FitData& d, Params& p) {
  return fit_lm(
      p, 200, [&d](const Params& q) { return residuals(d, q); },
      [&d](const Params& q) { return jacobian(d, q); }, [](Params& q) { clamp(q); });
}

// ---- Several modes: H(f) = sum_i g_i h_i(f), parameters (f_i, zeta_i, ln g_i) per mode. ----

/// h(f) for unit gain (complex), the form of `kind`.
cd unit_response(double fn, double zeta, double f, ModeKind kind) {
  const double w = kTwoPi * fn;
  const cd s(0.0, kTwoPi * f);
  const cd num = kind == ModeKind::base_damped ? 2.0 * zeta * w * s + w * w : cd(w * w, 0.0);
  return num / (s * s + 2.0 * zeta * w * s + w * w);
}

double multi_model_gain(const Eigen::VectorXd& p, double f, ModeKind kind) {
  cd h(0.0, 0.0);
  for (Eigen::Index i = 0; i + 2 < p.size(); i += 3) h += std::exp(p(i + 2)) * unit_response(p(i), p(i + 1), f, kind);
  return std::abs(h);
}

Eigen::VectorXd multi_residuals(const FitData& d, const Eigen::VectorXd& p) {
  Eigen::VectorXd r(static_cast<Eigen::Index>(d.f.size()));
  for (std::size_t k = 0; k < d.f.size(); ++k) {
    r(static_cast<Eigen::Index>(k)) =
        (std::log(std::max(multi_model_gain(p, d.f[k], d.kind), 1e-300)) - d.log_gain[k]) * d.sqrt_w[k];
  }
  return r;
}

Eigen::MatrixXd multi_jacobian(const FitData& d, const Eigen::VectorXd& p) {
  Eigen::MatrixXd j(static_cast<Eigen::Index>(d.f.size()), p.size());
  for (Eigen::Index c = 0; c < p.size(); ++c) {
    const double step = 1e-6 * std::max(std::abs(p(c)), 1e-3);
    Eigen::VectorXd a = p, b = p;
    a(c) += step;
    b(c) -= step;
    j.col(c) = (multi_residuals(d, a) - multi_residuals(d, b)) / (2.0 * step);
  }
  return j;
}

/// Bounds: f_n in [0.5 f_min, 2 f_max] of the fitted band, zeta in [1e-4, 0.95], |ln g| <= 30.
void multi_clamp(Eigen::VectorXd& p, double f_lo, double f_hi) {
  for (Eigen::Index i = 0; i + 2 < p.size(); i += 3) {
    p(i) = std::clamp(p(i), f_lo, f_hi);
    p(i + 1) = std::clamp(p(i + 1), 1e-4, 0.95);
    p(i + 2) = std::clamp(p(i + 2), -30.0, 30.0);
  }
}

/// Levenberg-Marquardt as levenberg_marquardt, on any number of modes.
std::pair<double, int> multi_levenberg_marquardt(const FitData& d, Eigen::VectorXd& p, double f_lo,
                                                 double f_hi) {
  multi_clamp(p, f_lo, f_hi);
  const double cost = multi_residuals(d, p).squaredNorm();
  if (!std::isfinite(cost)) return {cost, 0};
  return fit_lm(
      p, 300, [&d](const Eigen::VectorXd& q) { return multi_residuals(d, q); },
      [&d](const Eigen::VectorXd& q) { return multi_jacobian(d, q); },
      [f_lo, f_hi](Eigen::VectorXd& q) { multi_clamp(q, f_lo, f_hi); });
}

struct MultiFit {
  ModeKind kind = ModeKind::base_damped;
  Eigen::VectorXd p;
  double cost = std::numeric_limits<double>::infinity();
  int iterations = 0;
};

/// The N-mode fit from the (N-1)-mode one of the same kind: a new mode started at each of
/// the four largest local maxima of the log-gain excess (measured over model), with damping
/// ratios 0.02, 0.06, 0.15 and 0.3 and the gain that makes its peak the excess; plus a start
/// with a mode at each of the N highest local maxima of the measured gain. Each refined by
/// Levenberg-Marquardt; the lowest cost kept (of the fits whose modes are resolved, when
/// asked: the automatic choice).
/// Whether the modes of p are told apart: every pair further apart than the sum of their
/// half-power half-bandwidths (zeta_i f_i + zeta_j f_j), each half-power band 2 zeta f at
/// least two bins wide (2 df), each natural frequency inside the fitted band [f_first, f_last],
/// and each peak gain at least 5 % of the largest. A fit that
/// splits one mode into two close ones (to follow a slight misfit of its shape), puts a spike
/// between two bins, bends the roll-off with a mode outside the band, or adds a mode of no
/// consequence is not counted as more modes.
bool modes_resolved(const Eigen::VectorXd& p, ModeKind kind, double df, double f_first, double f_last) {
  const Eigen::Index n = p.size() / 3;
  std::vector<double> peak(static_cast<std::size_t>(n), 0.0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double fi = p(3 * i), zi = p(3 * i + 1), gi = std::exp(p(3 * i + 2));
    if (2.0 * zi * fi < 2.0 * df || fi < f_first || fi > f_last) return false;
    for (int g = 0; g <= 1800; ++g) {
      const double f = fi * (0.2 + 0.001 * g);
      peak[static_cast<std::size_t>(i)] = std::max(peak[static_cast<std::size_t>(i)], gi * std::abs(unit_response(fi, zi, f, kind)));
    }
    for (Eigen::Index j = 0; j < i; ++j) {
      const double fj = p(3 * j), zj = p(3 * j + 1);
      if (std::abs(fi - fj) <= zi * fi + zj * fj) return false;
    }
  }
  const double top = *std::max_element(peak.begin(), peak.end());
  for (const double v : peak)
    if (v < 0.05 * top) return false;
  return true;
}

MultiFit fit_next_mode(const FitData& d, const MultiFit& prev, double f_lo, double f_hi, double df,
                       bool require_resolved) {
  const std::size_t n = d.f.size();
  const auto modes = static_cast<std::size_t>(prev.p.size() / 3) + 1;
  std::vector<double> excess(n);
  for (std::size_t k = 0; k < n; ++k) {
    excess[k] = d.log_gain[k] - std::log(std::max(multi_model_gain(prev.p, d.f[k], d.kind), 1e-300));
  }
  auto local_maxima = [n](const std::vector<double>& v) {
    std::vector<std::size_t> idx;
    for (std::size_t k = 0; k < n; ++k) {
      const bool left = k == 0 || v[k] >= v[k - 1];
      const bool right = k + 1 == n || v[k] >= v[k + 1];
      if (left && right) idx.push_back(k);
    }
    std::stable_sort(idx.begin(), idx.end(), [&v](std::size_t a, std::size_t b) { return v[a] > v[b]; });
    return idx;
  };
  std::vector<Eigen::VectorXd> starts;
  const std::vector<std::size_t> ex_peaks = local_maxima(excess);
  for (std::size_t c = 0; c < std::min<std::size_t>(4, ex_peaks.size()); ++c) {
    const std::size_t k = ex_peaks[c];
    const double measured = std::exp(d.log_gain[k]);
    const double model = multi_model_gain(prev.p, d.f[k], d.kind);
    const double extra = std::max(measured - model, 0.05 * measured);
    for (const double zeta : {0.02, 0.06, 0.15, 0.3}) {
      Eigen::VectorXd q(prev.p.size() + 3);
      q.head(prev.p.size()) = prev.p;
      q.tail(3) << d.f[k], zeta, std::log(extra * 2.0 * zeta);
      starts.push_back(q);
    }
  }
  const std::vector<std::size_t> peaks = local_maxima(d.log_gain);
  if (peaks.size() >= modes) {
    Eigen::VectorXd q(static_cast<Eigen::Index>(3 * modes));
    for (std::size_t i = 0; i < modes; ++i) {
      const std::size_t k = peaks[i];
      q.segment(static_cast<Eigen::Index>(3 * i), 3) << d.f[k], 0.08,
          std::log(std::exp(d.log_gain[k]) * 2.0 * 0.08 / static_cast<double>(modes));
    }
    starts.push_back(q);
  }
  MultiFit best;
  best.kind = d.kind;
  for (Eigen::VectorXd q : starts) {
    const auto [cost, it] = multi_levenberg_marquardt(d, q, f_lo, f_hi);
    if (require_resolved && !modes_resolved(q, d.kind, df, d.f.front(), d.f.back())) continue;
    if (std::isfinite(cost) && cost < best.cost) {
      best.cost = cost;
      best.p = q;
      best.iterations = it;
    }
  }
  return best;
}

double parse_field(std::string_view field, std::string_view text) {
  double v = 0.0;
  while (!field.empty() && field.front() == ' ') field.remove_prefix(1);
  while (!field.empty() && field.back() == ' ') field.remove_suffix(1);
  const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
  if (field.empty() || ec != std::errc() || ptr != field.data() + field.size() || !std::isfinite(v)) {
    throw Error(fmt::format("sweep '{}': '{}' is not a number; expected F0,F1,RATE,ACCEL (Hz, Hz, "
                            "Hz/s, mm/s^2)",
                            text, field));
  }
  return v;
}

}  // namespace

double model_gain(const ModalFit& f, double freq_hz) {
  if (f.modes.size() <= 1) return f.gain * unit_gain(f.natural_frequency_hz, f.damping_ratio, freq_hz, f.kind);
  cd h(0.0, 0.0);
  for (const ModeEstimate& m : f.modes) h += m.gain * unit_response(m.natural_frequency_hz, m.damping_ratio, freq_hz, f.kind);
  return std::abs(h);
}

std::string_view to_string(ModeSelection selection) {
  return selection == ModeSelection::asked ? "asked" : "bic";
}

std::string_view to_string(ModeKind kind) {
  return kind == ModeKind::base_damped ? "base_damped" : "ground_damped";
}

SweepExcitation parse_sweep(std::string_view text) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = text.find(',', start);
    parts.push_back(text.substr(start, comma == std::string_view::npos ? text.npos : comma - start));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  if (parts.size() != 4) {
    throw Error(fmt::format("sweep '{}': {} values, expected 4: F0,F1,RATE,ACCEL (Hz, Hz, Hz/s, "
                            "mm/s^2)",
                            text, parts.size()));
  }
  SweepExcitation s{parse_field(parts[0], text), parse_field(parts[1], text),
                    parse_field(parts[2], text), parse_field(parts[3], text)};
  if (!(s.f0_hz > 0) || !(s.f1_hz > s.f0_hz) || !(s.rate_hz_s > 0) || !(s.accel_mm_s2 > 0)) {
    throw Error(fmt::format("sweep '{}': expected 0 < F0 < F1, RATE > 0 and ACCEL > 0", text));
  }
  return s;
}

SweepIdentification identify_sweep(const AccelRecord& record, char axis, const SweepExcitation& sweep,
                                   int mode_count) {
  if (axis != 'x' && axis != 'y') throw Error(fmt::format("axis must be x or y, got '{}'", axis));
  if (mode_count < 0 || mode_count > kMaxModes) {
    throw Error(fmt::format("--modes: must be 1 to {} (or automatic), got {}", kMaxModes, mode_count));
  }
  const RecordQuality q = assess_record(record);
  const double fs = q.sample_rate_hz;
  if (sweep.f1_hz >= 0.5 * fs) {
    throw Error(fmt::format("{}: sweep end {} Hz is not below the Nyquist frequency {} Hz",
                            record.source, sweep.f1_hz, 0.5 * fs));
  }
  const std::vector<double>& raw = axis == 'x' ? record.accel_x_mm_s2 : record.accel_y_mm_s2;
  double mean = 0.0;
  for (const double v : raw) mean += v;
  mean /= static_cast<double>(raw.size());
  std::vector<double> y(raw.size());
  for (std::size_t i = 0; i < raw.size(); ++i) y[i] = raw[i] - mean;

  const double duration = (sweep.f1_hz - sweep.f0_hz) / sweep.rate_hz_s;
  SweepIdentification out;
  out.sweep = sweep;
  // 1. Alignment: the start t0 and the time scale k (the record's clock against the one the
  // sweep was commanded with: the record holds chirp(k (t - t0))), by the largest normalised
  // correlation with the chirp over t0, for k on a coarse then a fine grid.
  struct Peak {
    double k = 1.0;
    double lag = 0.0;
    double value = -1.0;
  };
  const std::vector<double> y_white = whiten(y, fs);
  auto align = [&](double k) {
    const auto len = static_cast<std::size_t>(std::floor(duration / k * fs)) + 1;
    if (len + 1 >= y.size()) return Peak{k, 0.0, -1.0};
    const std::vector<double> corr = chirp_correlation(y_white, sweep, fs, k, len);
    const auto best = static_cast<std::size_t>(std::max_element(corr.begin(), corr.end()) - corr.begin());
    double lag = static_cast<double>(best);
    if (best > 0 && best + 1 < corr.size()) {
      const double a = corr[best - 1], b = corr[best], c = corr[best + 1];
      const double den = a - 2.0 * b + c;
      if (den < 0) lag += 0.5 * (a - c) / den;
    }
    return Peak{k, lag, corr[best]};
  };
  Peak best = align(1.0);
  if (best.value < 0) {
    throw Error(fmt::format("{}: the sweep lasts {:.4g} s, longer than the record ({:.4g} s)",
                            record.source, duration, q.duration_s));
  }
  for (double k = 0.95; k <= 1.0501; k += 0.005) {
    const Peak p = align(k);
    if (p.value > best.value) best = p;
  }
  const double k_coarse = best.k;
  for (double k = k_coarse - 0.004; k <= k_coarse + 0.00401; k += 0.001) {
    const Peak p = align(k);
    if (p.value > best.value) best = p;
  }
  const double lag = best.lag;
  const double k_scale = best.k;
  out.time_scale = k_scale;
  out.alignment_peak = best.value;
  out.sweep_start_s = record.time_s.front() + lag / fs;
  const double duration_rec = duration / k_scale;  // the sweep's length on the record's clock

  // 2. Frequency response: Welch cross-spectra over the sweep and 0.5 s after it.
  std::vector<double> u(y.size(), 0.0);
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double t = record.time_s[i] - out.sweep_start_s;
    if (t >= 0 && t <= duration_rec) u[i] = sweep.accel_mm_s2 * std::sin(sweep_phase(sweep, k_scale * t));
  }
  const auto first = static_cast<std::size_t>(std::max(0.0, std::floor(lag - 0.25 * fs)));
  const std::size_t last = std::min(y.size(), static_cast<std::size_t>(lag + (duration_rec + 0.5) * fs));
  const std::size_t m = klipper_segment_samples(2.0 * fs);  // about 1 s segments
  if (last - first <= m) {
    throw Error(fmt::format("{}: the sweep window holds {} samples, expected more than {}",
                            record.source, last - first, m));
  }
  out.segment_samples = m;
  // Kaiser beta 6, as the PSD.
  numerics::WelchSegments welch(m, numerics::kaiser_window(m, kKlipperKaiserBeta));
  const std::size_t step = welch.step();
  const std::size_t segments = (last - first - m / 2) / step;
  const std::size_t bins = welch.bins();
  std::vector<cd> suy(bins), fu(bins);
  std::vector<double> suu(bins, 0.0), syy(bins, 0.0);
  for (std::size_t sgi = 0; sgi < segments; ++sgi) {
    const std::size_t s0 = first + sgi * step;
    const auto tu = welch.transform(u.data() + s0);
    std::copy(tu.begin(), tu.end(), fu.begin());
    const auto fy = welch.transform(y.data() + s0);
    for (std::size_t k = 0; k < bins; ++k) {
      const cd a = fu[k];
      const cd b = fy[k];
      suy[k] += std::conj(a) * b;
      suu[k] += std::norm(a);
      syy[k] += std::norm(b);
    }
  }
  const double suu_max = *std::max_element(suu.begin(), suu.end());
  const double df = fs / static_cast<double>(m);
  FitData data;
  out.response.resize(bins);
  for (std::size_t k = 0; k < bins; ++k) {
    ResponseBin& b = out.response[k];
    b.freq_hz = static_cast<double>(k) * df;
    if (suu[k] <= 0 || syy[k] <= 0) continue;
    const cd h = suy[k] / suu[k];
    b.gain = std::abs(h);
    b.phase_rad = std::arg(h);
    b.coherence = std::norm(suy[k]) / (suu[k] * syy[k]);
    b.used = b.freq_hz >= sweep.f0_hz / k_scale + 2 * df && b.freq_hz <= sweep.f1_hz / k_scale - 2 * df &&
             b.coherence >= 0.5 && suu[k] >= 1e-3 * suu_max;
    if (!b.used) continue;
    // The relative error of |H1| goes as sqrt((1 - gamma^2) / gamma^2); capped so that no
    // bin weighs more than 0.999 coherence would.
    const double g2 = std::min(b.coherence, 0.999);
    data.f.push_back(b.freq_hz);
    data.log_gain.push_back(std::log(std::max(b.gain, 1e-300)));
    data.sqrt_w.push_back(std::sqrt(g2 / (1.0 - g2)));
  }
  if (data.f.size() < 8) {
    throw Error(fmt::format("{}: {} coherent bins in the sweep band, expected at least 8 (is the "
                            "sweep on axis {} of this record?)",
                            record.source, data.f.size(), axis));
  }
  // 3. Modal fit of the gain |H1| (the phase also holds what the alignment leaves, a delay
  // growing with the frequency; the gain does not), from the best point of a grid.
  std::size_t peak = 0;
  for (std::size_t k = 1; k < data.f.size(); ++k)
    if (data.log_gain[k] > data.log_gain[peak]) peak = k;
  double best_cost = std::numeric_limits<double>::infinity();
  Params best_p{};
  int best_it = 0;
  ModeKind best_kind = ModeKind::base_damped;
  std::array<MultiFit, 2> one_mode;  // per kind: the seeds of the fits with more modes
  for (const ModeKind kind : {ModeKind::base_damped, ModeKind::ground_damped}) {
    data.kind = kind;
    Params p = grid_start(data, data.f[peak], df);
    const auto [cost, it] = levenberg_marquardt(data, p);
    MultiFit& seed = one_mode[kind == ModeKind::base_damped ? 0 : 1];
    seed.kind = kind;
    seed.p = Eigen::Vector3d(p[0], p[1], p[2]);
    seed.cost = cost;
    seed.iterations = it;
    if (cost < best_cost) {
      best_cost = cost;
      best_p = p;
      best_it = it;
      best_kind = kind;
    }
  }
  data.kind = best_kind;
  ModalFit& fit = out.model;
  fit.kind = best_kind;
  fit.natural_frequency_hz = best_p[0];
  fit.damping_ratio = best_p[1];
  fit.gain = std::exp(best_p[2]);
  fit.bins_used = data.f.size();
  fit.iterations = best_it;
  const double dof = std::max(1.0, static_cast<double>(data.f.size()) - 3.0);
  const double s2 = best_cost / dof;
  fit.rms_residual = std::sqrt(s2);
  const Eigen::MatrixXd j = jacobian(data, best_p);
  const Eigen::MatrixXd cov = (j.transpose() * j).inverse() * s2;
  fit.natural_frequency_std_hz = std::sqrt(std::max(0.0, cov(0, 0)));
  fit.damping_ratio_std = std::sqrt(std::max(0.0, cov(1, 1)));
  fit.gain_std = fit.gain * std::sqrt(std::max(0.0, cov(2, 2)));
  fit.modes.push_back(ModeEstimate{fit.natural_frequency_hz, fit.natural_frequency_std_hz, fit.damping_ratio,
                                   fit.damping_ratio_std, fit.gain, fit.gain_std, 0.0});
  {
    double peak_gain = 0.0;  // max over f of g |h(f)|, on a 0.1 % grid from 0.2 f_n to 2 f_n
    for (int i = 0; i <= 1800; ++i) {
      const double f = fit.natural_frequency_hz * (0.2 + 0.001 * i);
      peak_gain = std::max(peak_gain, fit.gain * unit_gain(fit.natural_frequency_hz, fit.damping_ratio, f, fit.kind));
    }
    fit.modes.front().peak_gain = peak_gain;
  }
  // 4. More modes: N = 2..max from N - 1 (per kind), BIC(N) = n ln(RSS / n) + 3 N ln n; the
  // automatic choice only counts fits whose modes are resolved (modes_resolved).
  const auto n_bins = static_cast<double>(data.f.size());
  auto bic = [n_bins](double cost, int modes) {
    return n_bins * std::log(std::max(cost, 1e-300) / n_bins) + 3.0 * modes * std::log(n_bins);
  };
  fit.selection = mode_count == 0 ? ModeSelection::bic : ModeSelection::asked;
  fit.bic.push_back(bic(best_cost, 1));
  const int max_modes = mode_count == 0 ? kMaxModes : mode_count;
  const double f_lo = 0.5 * data.f.front();
  const double f_hi = 2.0 * data.f.back();
  std::array<MultiFit, 2> prev = one_mode;
  MultiFit chosen;
  int chosen_modes = 1;
  double chosen_bic = fit.bic.front();
  for (int nm = 2; nm <= max_modes; ++nm) {
    // A fit needs more bins than parameters (and some to spare for its residual).
    if (data.f.size() < static_cast<std::size_t>(3 * nm + 5)) break;
    MultiFit best_n;
    for (std::size_t kk = 0; kk < 2; ++kk) {
      data.kind = prev[kk].kind;
      MultiFit f = fit_next_mode(data, prev[kk], f_lo, f_hi, df, mode_count == 0);
      if (f.p.size() == 0) f = prev[kk];  // no start: keep the smaller model's
      prev[kk] = f;
      if (f.p.size() == Eigen::Index{3} * nm && f.cost < best_n.cost) best_n = f;
    }
    if (best_n.p.size() != Eigen::Index{3} * nm) break;
    const double b = bic(best_n.cost, nm);
    fit.bic.push_back(b);
    if (mode_count == nm || (mode_count == 0 && b < chosen_bic)) {
      chosen = best_n;
      chosen_modes = nm;
      chosen_bic = b;
    }
  }
  if (mode_count > 1 && chosen_modes != mode_count) {
    throw Error(fmt::format("{}: {} coherent bins are too few for --modes {}", record.source,
                            data.f.size(), mode_count));
  }
  if (chosen_modes > 1) {
    data.kind = chosen.kind;
    const Eigen::Index np = chosen.p.size();
    const double dof_n = std::max(1.0, n_bins - static_cast<double>(np));
    const double s2_n = chosen.cost / dof_n;
    const Eigen::MatrixXd jn = multi_jacobian(data, chosen.p);
    const Eigen::MatrixXd cov_n = (jn.transpose() * jn).completeOrthogonalDecomposition().pseudoInverse() * s2_n;
    fit.modes.clear();
    for (Eigen::Index i = 0; i < np; i += 3) {
      ModeEstimate m;
      m.natural_frequency_hz = chosen.p(i);
      m.damping_ratio = chosen.p(i + 1);
      m.gain = std::exp(chosen.p(i + 2));
      m.natural_frequency_std_hz = std::sqrt(std::max(0.0, cov_n(i, i)));
      m.damping_ratio_std = std::sqrt(std::max(0.0, cov_n(i + 1, i + 1)));
      m.gain_std = m.gain * std::sqrt(std::max(0.0, cov_n(i + 2, i + 2)));
      for (int g = 0; g <= 1800; ++g) {
        const double f = m.natural_frequency_hz * (0.2 + 0.001 * g);
        m.peak_gain = std::max(m.peak_gain, m.gain * unit_gain(m.natural_frequency_hz, m.damping_ratio, f, chosen.kind));
      }
      fit.modes.push_back(m);
    }
    std::sort(fit.modes.begin(), fit.modes.end(), [](const ModeEstimate& a, const ModeEstimate& b) {
      return a.natural_frequency_hz < b.natural_frequency_hz;
    });
    fit.dominant_mode = 0;
    for (std::size_t i = 1; i < fit.modes.size(); ++i)
      if (fit.modes[i].peak_gain > fit.modes[fit.dominant_mode].peak_gain) fit.dominant_mode = i;
    const ModeEstimate& dom = fit.modes[fit.dominant_mode];
    fit.kind = chosen.kind;
    fit.natural_frequency_hz = dom.natural_frequency_hz;
    fit.natural_frequency_std_hz = dom.natural_frequency_std_hz;
    fit.damping_ratio = dom.damping_ratio;
    fit.damping_ratio_std = dom.damping_ratio_std;
    fit.gain = dom.gain;
    fit.gain_std = dom.gain_std;
    fit.rms_residual = std::sqrt(s2_n);
    fit.iterations = chosen.iterations;
  }
  return out;
}

}  // namespace amctl::resonance
