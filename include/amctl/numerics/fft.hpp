#pragma once
// Real discrete Fourier transforms (FFTW) and Welch's segment-averaged spectra.
//
// One plan per length, made with FFTW_ESTIMATE on buffers from fftw_malloc: the plan, and so
// every bit of the result, depends only on the length (never on timing), so two runs give the
// same numbers. docs/numerics.md.
#include <complex>
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

namespace amctl::numerics {

/// The forward transform X_k = sum_n x_n e^{-2 pi i k n / N}, k = 0 .. N/2, of a real signal of
/// length N, and its unnormalised inverse (N x_n back). Holds its buffers; not copyable.
class RealFft {
 public:
  explicit RealFft(std::size_t n);
  ~RealFft();
  RealFft(const RealFft&) = delete;
  RealFft& operator=(const RealFft&) = delete;
  RealFft(RealFft&&) noexcept;
  RealFft& operator=(RealFft&&) noexcept;

  [[nodiscard]] std::size_t size() const { return n_; }
  /// N / 2 + 1.
  [[nodiscard]] std::size_t bins() const { return n_ / 2 + 1; }
  /// The time-domain buffer (N values): forward() reads it, inverse() writes it.
  [[nodiscard]] std::span<double> signal();
  /// The frequency-domain buffer (bins() values): forward() writes it, inverse() reads (and
  /// overwrites) it.
  [[nodiscard]] std::span<std::complex<double>> spectrum();
  /// signal -> spectrum; the signal is kept.
  void forward();
  /// spectrum -> signal, unnormalised (N times the signal whose spectrum it is); the spectrum
  /// is destroyed.
  void inverse();

 private:
  struct Impl;
  std::size_t n_ = 0;
  std::unique_ptr<Impl> impl_;
};

/// Modified Bessel function of the first kind, order 0, by its power series
/// sum_k ((x/2)^k / k!)^2 (summed until a term falls below 1e-18 of the sum).
[[nodiscard]] double bessel_i0(double x);

/// The Kaiser window of m points, as numpy.kaiser(m, beta):
/// w_n = I0(beta sqrt(1 - ((n - a) / a)^2)) / I0(beta), a = (m - 1) / 2.
[[nodiscard]] std::vector<double> kaiser_window(std::size_t m, double beta);

/// Welch's method, the segment side: each segment of m samples has its mean removed, is
/// multiplied by the window and transformed. Segments of m samples step by m - m/2 (half
/// overlap), as numpy/scipy and Klipper's shaper calibration cut them.
class WelchSegments {
 public:
  WelchSegments(std::size_t m, std::vector<double> window);
  [[nodiscard]] std::size_t segment_samples() const { return fft_.size(); }
  [[nodiscard]] std::size_t bins() const { return fft_.bins(); }
  /// m - m/2.
  [[nodiscard]] std::size_t step() const { return fft_.size() - fft_.size() / 2; }
  /// The number of whole segments in n samples: (n - m/2) / step (0 when n < m).
  [[nodiscard]] std::size_t segments_in(std::size_t n) const;
  /// sum_n w_n^2.
  [[nodiscard]] double window_energy() const { return window_energy_; }
  /// The transform of the segment starting at `first` (m samples read); valid until the next
  /// call.
  std::span<const std::complex<double>> transform(const double* first);

 private:
  RealFft fft_;
  std::vector<double> window_;
  double window_energy_ = 0.0;
};

}  // namespace amctl::numerics
