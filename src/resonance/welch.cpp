// Klipper's Welch PSD (shaper_calibrate.py: calc_freq_response, _psd, _split_into_windows)
// and normalize_to_frequencies, computed with FFTW. docs/resonance.md has the equations.
#include <fftw3.h>

#include <cmath>
#include <complex>
#include <memory>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::resonance {
namespace {

/// Modified Bessel function of the first kind, order 0, by its power series
/// sum_k ((x/2)^k / k!)^2 (for |x| <= 6 the terms fall below 1e-17 of the sum by k = 30).
double bessel_i0(double x) {
  const double q = 0.25 * x * x;
  double term = 1.0;
  double sum = 1.0;
  for (int k = 1; k < 200; ++k) {
    term *= q / (static_cast<double>(k) * static_cast<double>(k));
    sum += term;
    if (term < sum * 1e-18) break;
  }
  return sum;
}

/// numpy.kaiser(m, beta): i0(beta sqrt(1 - ((n - a) / a)^2)) / i0(beta), a = (m - 1) / 2.
std::vector<double> kaiser(std::size_t m, double beta) {
  std::vector<double> w(m, 1.0);
  if (m == 1) return w;
  const double alpha = (static_cast<double>(m) - 1.0) / 2.0;
  const double denom = bessel_i0(beta);
  for (std::size_t n = 0; n < m; ++n) {
    const double r = (static_cast<double>(n) - alpha) / alpha;
    w[n] = bessel_i0(beta * std::sqrt(std::max(0.0, 1.0 - r * r))) / denom;
  }
  return w;
}

struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};
struct PlanFree {
  void operator()(fftw_plan_s* p) const { fftw_destroy_plan(p); }
};

/// Welch over one axis with a prepared plan and buffers.
class Welch {
 public:
  Welch(std::size_t m, double fs)
      : m_(m),
        fs_(fs),
        window_(kaiser(m, kKlipperKaiserBeta)),
        in_(static_cast<double*>(fftw_malloc(sizeof(double) * m))),
        out_(static_cast<fftw_complex*>(fftw_malloc(sizeof(fftw_complex) * (m / 2 + 1)))) {
    if (!in_ || !out_) throw std::bad_alloc();
    // FFTW_ESTIMATE: the plan (and so every bit of the result) does not depend on timing.
    plan_.reset(fftw_plan_dft_r2c_1d(static_cast<int>(m), in_.get(), out_.get(), FFTW_ESTIMATE));
    AMCTL_CHECK(plan_ != nullptr, "fftw_plan_dft_r2c_1d failed");
    double sum_sq = 0.0;
    for (const double w : window_) sum_sq += w * w;
    scale_ = 1.0 / sum_sq;
  }

  /// PSD of x (segments of m, step m - m/2), as numpy computes it in _psd.
  std::vector<double> psd(const std::vector<double>& x, std::size_t segments) {
    const std::size_t bins = m_ / 2 + 1;
    const std::size_t step = m_ - m_ / 2;
    std::vector<double> acc(bins, 0.0);
    for (std::size_t s = 0; s < segments; ++s) {
      const double* seg = x.data() + s * step;
      double mean = 0.0;
      for (std::size_t i = 0; i < m_; ++i) mean += seg[i];
      mean /= static_cast<double>(m_);
      for (std::size_t i = 0; i < m_; ++i) in_.get()[i] = window_[i] * (seg[i] - mean);
      fftw_execute(plan_.get());
      for (std::size_t k = 0; k < bins; ++k) {
        const double re = out_.get()[k][0];
        const double im = out_.get()[k][1];
        double p = (re * re + im * im) * (scale_ / fs_);
        if (k != 0 && k + 1 != bins) p *= 2.0;
        acc[k] += p;
      }
    }
    for (double& v : acc) v /= static_cast<double>(segments);
    return acc;
  }

 private:
  std::size_t m_;
  double fs_;
  std::vector<double> window_;
  std::unique_ptr<double, FftwFree> in_;
  std::unique_ptr<fftw_complex, FftwFree> out_;
  std::unique_ptr<fftw_plan_s, PlanFree> plan_;
  double scale_ = 0.0;
};

}  // namespace

std::size_t klipper_segment_samples(double sample_rate_hz) {
  // 1 << int(fs * WINDOW_T_SEC - 1).bit_length()  (Python's int() truncates toward zero).
  const double v = sample_rate_hz * kKlipperWindowS - 1.0;
  if (!(v < 1e15)) return std::size_t{1} << 50;
  long long i = static_cast<long long>(v);
  if (i < 0) i = -i;
  std::size_t bits = 0;
  while (i > 0) {
    ++bits;
    i >>= 1;
  }
  return std::size_t{1} << bits;
}

WelchPsd klipper_psd(const AccelRecord& record) {
  const std::size_t n = record.size();
  if (n < 2) throw Error(fmt::format("{}: {} samples, expected more than one Welch segment", record.source, n));
  const double duration = record.time_s.back() - record.time_s.front();
  WelchPsd out;
  out.sample_rate_hz = static_cast<double>(n) / duration;
  out.segment_samples = klipper_segment_samples(out.sample_rate_hz);
  const std::size_t m = out.segment_samples;
  if (n <= m || m < 4) {
    throw Error(fmt::format("{}: {} samples, expected more than {} (one Welch segment of {} s)",
                            record.source, n, std::max<std::size_t>(m, 4), kKlipperWindowS));
  }
  const std::size_t overlap = m / 2;
  const std::size_t step = m - overlap;
  out.segments = (n - overlap) / step;
  Welch welch(m, out.sample_rate_hz);
  PsdTable& t = out.table;
  t.psd_x = welch.psd(record.accel_x_mm_s2, out.segments);
  t.psd_y = welch.psd(record.accel_y_mm_s2, out.segments);
  t.psd_z = welch.psd(record.accel_z_mm_s2, out.segments);
  const std::size_t bins = m / 2 + 1;
  t.psd_xyz.resize(bins);
  t.freq_hz.resize(bins);
  // numpy.fft.rfftfreq(m, 1/fs): k * (1 / (m * (1/fs))).
  const double d = 1.0 / out.sample_rate_hz;
  const double val = 1.0 / (static_cast<double>(m) * d);
  for (std::size_t k = 0; k < bins; ++k) {
    t.psd_xyz[k] = t.psd_x[k] + t.psd_y[k] + t.psd_z[k];
    t.freq_hz[k] = static_cast<double>(k) * val;
  }
  t.normalized = false;
  return out;
}

void normalize_to_frequencies(PsdTable& psd) {
  if (psd.normalized) return;
  for (std::vector<double>* v : {&psd.psd_xyz, &psd.psd_x, &psd.psd_y, &psd.psd_z}) {
    for (std::size_t k = 0; k < v->size(); ++k) {
      const double f = psd.freq_hz[k];
      double p = (*v)[k] / (f + 0.1);
      if (f < 2.0 * kKlipperMinFreqHz) {
        const double r = 2.0 * kKlipperMinFreqHz / (f + 0.1);
        p *= std::exp(-(r * r) + 1.0);
      }
      (*v)[k] = p;
    }
  }
  psd.normalized = true;
}

}  // namespace amctl::resonance
