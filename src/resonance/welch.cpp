// Klipper's Welch PSD (shaper_calibrate.py: calc_freq_response, _psd, _split_into_windows)
// and normalize_to_frequencies, on numerics::WelchSegments (FFTW). docs/resonance.md has the equations.
#include <cmath>
#include <complex>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/numerics/fft.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::resonance {
namespace {

/// The PSD of x over `segments` Welch segments, one-sided, as numpy computes it in Klipper's
/// _psd: |X_k|^2 / (fs sum w^2), doubled except at 0 and the Nyquist bin, averaged.
std::vector<double> klipper_welch_psd(numerics::WelchSegments& welch, const std::vector<double>& x,
                                      std::size_t segments, double fs) {
  const std::size_t bins = welch.bins();
  const double scale = 1.0 / welch.window_energy();
  std::vector<double> acc(bins, 0.0);
  for (std::size_t s = 0; s < segments; ++s) {
    const auto spec = welch.transform(x.data() + s * welch.step());
    for (std::size_t k = 0; k < bins; ++k) {
      double p = std::norm(spec[k]) * (scale / fs);
      if (k != 0 && k + 1 != bins) p *= 2.0;
      acc[k] += p;
    }
  }
  for (double& v : acc) v /= static_cast<double>(segments);
  return acc;
}

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
  numerics::WelchSegments welch(m, numerics::kaiser_window(m, kKlipperKaiserBeta));
  PsdTable& t = out.table;
  const double fs = out.sample_rate_hz;
  t.psd_x = klipper_welch_psd(welch, record.accel_x_mm_s2, out.segments, fs);
  t.psd_y = klipper_welch_psd(welch, record.accel_y_mm_s2, out.segments, fs);
  t.psd_z = klipper_welch_psd(welch, record.accel_z_mm_s2, out.segments, fs);
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
