// Sweep alignment, frequency response and modal fit (sweep.hpp; docs/resonance.md §6).
#include "amctl/resonance/sweep.hpp"

#include <fftw3.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <complex>
#include <memory>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::resonance {
namespace {

using cd = std::complex<double>;
constexpr double kTwoPi = 2.0 * std::numbers::pi;

struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};
struct PlanFree {
  void operator()(fftw_plan_s* p) const { fftw_destroy_plan(p); }
};
template <class T>
std::unique_ptr<T, FftwFree> fftw_array(std::size_t n) {
  auto* p = static_cast<T*>(fftw_malloc(sizeof(T) * n));
  if (!p) throw std::bad_alloc();
  return std::unique_ptr<T, FftwFree>(p);
}

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
  const std::size_t bins = p / 2 + 1;
  auto in = fftw_array<double>(p);
  auto out_y = fftw_array<fftw_complex>(bins);
  auto out_c = fftw_array<fftw_complex>(bins);
  auto prod = fftw_array<fftw_complex>(bins);
  auto back = fftw_array<double>(p);
  std::unique_ptr<fftw_plan_s, PlanFree> fwd_y(
      fftw_plan_dft_r2c_1d(static_cast<int>(p), in.get(), out_y.get(), FFTW_ESTIMATE));
  std::unique_ptr<fftw_plan_s, PlanFree> fwd_c(
      fftw_plan_dft_r2c_1d(static_cast<int>(p), in.get(), out_c.get(), FFTW_ESTIMATE));
  std::unique_ptr<fftw_plan_s, PlanFree> inv(
      fftw_plan_dft_c2r_1d(static_cast<int>(p), prod.get(), back.get(), FFTW_ESTIMATE));
  AMCTL_CHECK(fwd_y && fwd_c && inv, "fftw plan failed");

  std::fill(in.get(), in.get() + p, 0.0);
  std::copy(y.begin(), y.end(), in.get());
  fftw_execute(fwd_y.get());

  const std::size_t lags = n - len + 1;
  std::vector<double> sum_sq(lags, 0.0);
  std::vector<double> mag2(lags, 0.0);
  for (int part = 0; part < 2; ++part) {
    std::fill(in.get(), in.get() + p, 0.0);
    for (std::size_t i = 0; i < len; ++i) {
      const double ph = sweep_phase(s, k_scale * static_cast<double>(i) / fs);
      in.get()[i] = part == 0 ? std::cos(ph) : std::sin(ph);
    }
    fftw_execute(fwd_c.get());
    for (std::size_t k = 0; k < bins; ++k) {
      const cd a(out_y.get()[k][0], out_y.get()[k][1]);
      const cd b(out_c.get()[k][0], out_c.get()[k][1]);
      const cd r = a * std::conj(b);
      prod.get()[k][0] = r.real();
      prod.get()[k][1] = r.imag();
    }
    fftw_execute(inv.get());
    for (std::size_t l = 0; l < lags; ++l) {
      const double c = back.get()[l] / static_cast<double>(p);
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
  const std::size_t bins = p / 2 + 1;
  auto in = fftw_array<double>(p);
  auto spec = fftw_array<fftw_complex>(bins);
  std::unique_ptr<fftw_plan_s, PlanFree> fwd(
      fftw_plan_dft_r2c_1d(static_cast<int>(p), in.get(), spec.get(), FFTW_ESTIMATE));
  std::unique_ptr<fftw_plan_s, PlanFree> inv(
      fftw_plan_dft_c2r_1d(static_cast<int>(p), spec.get(), in.get(), FFTW_ESTIMATE));
  AMCTL_CHECK(fwd && inv, "fftw plan failed");
  std::fill(in.get(), in.get() + p, 0.0);
  std::copy(y.begin(), y.end(), in.get());
  fftw_execute(fwd.get());
  std::vector<double> mag(bins);
  for (std::size_t k = 0; k < bins; ++k) mag[k] = std::hypot(spec.get()[k][0], spec.get()[k][1]);
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
    spec.get()[k][0] *= scale;
    spec.get()[k][1] *= scale;
  }
  fftw_execute(inv.get());
  std::vector<double> out(y.size());
  for (std::size_t i = 0; i < y.size(); ++i) out[i] = in.get()[i] / static_cast<double>(p);
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

/// Levenberg-Marquardt from p; returns the cost sum r^2 and the iterations.
std::pair<double, int> levenberg_marquardt(const FitData& d, Params& p) {
  double lambda = 1e-3;
  Eigen::VectorXd r = residuals(d, p);
  double cost = r.squaredNorm();
  int it = 0;
  for (; it < 200; ++it) {
    const Eigen::MatrixXd j = jacobian(d, p);
    const Eigen::MatrixXd jtj = j.transpose() * j;
    const Eigen::VectorXd g = j.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 30; ++tries) {
      Eigen::MatrixXd a = jtj;
      for (int c = 0; c < 3; ++c) a(c, c) += lambda * std::max(jtj(c, c), 1e-12);
      const Eigen::VectorXd delta = a.ldlt().solve(-g);
      Params q = p;
      for (int c = 0; c < 3; ++c) q[c] += delta(c);
      clamp(q);
      const Eigen::VectorXd rq = residuals(d, q);
      const double cq = rq.squaredNorm();
      if (std::isfinite(cq) && cq < cost) {
        const double rel = (cost - cq) / std::max(cost, 1e-300);
        p = q;
        r = rq;
        cost = cq;
        lambda = std::max(lambda / 3.0, 1e-12);
        improved = true;
        if (rel < 1e-13) return {cost, it + 1};
        break;
      }
      lambda *= 4.0;
    }
    if (!improved) break;
  }
  return {cost, it};
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
  return f.gain * unit_gain(f.natural_frequency_hz, f.damping_ratio, freq_hz, f.kind);
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

SweepIdentification identify_sweep(const AccelRecord& record, char axis, const SweepExcitation& sweep) {
  if (axis != 'x' && axis != 'y') throw Error(fmt::format("axis must be x or y, got '{}'", axis));
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
  const std::size_t step = m - m / 2;
  const std::size_t segments = (last - first - m / 2) / step;
  const std::size_t bins = m / 2 + 1;
  std::vector<double> window(m);
  {  // Kaiser beta 6, as the PSD
    auto i0 = [](double x) {
      const double q4 = 0.25 * x * x;
      double term = 1.0, sum = 1.0;
      for (int k = 1; k < 200 && term > sum * 1e-18; ++k) {
        term *= q4 / (static_cast<double>(k) * k);
        sum += term;
      }
      return sum;
    };
    const double alpha = (static_cast<double>(m) - 1.0) / 2.0;
    for (std::size_t n = 0; n < m; ++n) {
      const double r = (static_cast<double>(n) - alpha) / alpha;
      window[n] = i0(kKlipperKaiserBeta * std::sqrt(std::max(0.0, 1.0 - r * r))) / i0(kKlipperKaiserBeta);
    }
  }
  auto in = fftw_array<double>(m);
  auto fu = fftw_array<fftw_complex>(bins);
  auto fy = fftw_array<fftw_complex>(bins);
  std::unique_ptr<fftw_plan_s, PlanFree> pu(
      fftw_plan_dft_r2c_1d(static_cast<int>(m), in.get(), fu.get(), FFTW_ESTIMATE));
  std::unique_ptr<fftw_plan_s, PlanFree> py(
      fftw_plan_dft_r2c_1d(static_cast<int>(m), in.get(), fy.get(), FFTW_ESTIMATE));
  std::vector<cd> suy(bins);
  std::vector<double> suu(bins, 0.0), syy(bins, 0.0);
  for (std::size_t sgi = 0; sgi < segments; ++sgi) {
    const std::size_t s0 = first + sgi * step;
    for (const bool is_u : {true, false}) {
      const std::vector<double>& x = is_u ? u : y;
      double mu = 0.0;
      for (std::size_t i = 0; i < m; ++i) mu += x[s0 + i];
      mu /= static_cast<double>(m);
      for (std::size_t i = 0; i < m; ++i) in.get()[i] = window[i] * (x[s0 + i] - mu);
      fftw_execute(is_u ? pu.get() : py.get());
    }
    for (std::size_t k = 0; k < bins; ++k) {
      const cd a(fu.get()[k][0], fu.get()[k][1]);
      const cd b(fy.get()[k][0], fy.get()[k][1]);
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
  for (const ModeKind kind : {ModeKind::base_damped, ModeKind::ground_damped}) {
    data.kind = kind;
    Params p = grid_start(data, data.f[peak], df);
    const auto [cost, it] = levenberg_marquardt(data, p);
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
  return out;
}

}  // namespace amctl::resonance
