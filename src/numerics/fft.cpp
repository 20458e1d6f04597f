// Real FFTs through FFTW, the Kaiser window and Welch segments (fft.hpp; docs/numerics.md).
#include "amctl/numerics/fft.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <new>

#include "amctl/core/error.hpp"

namespace amctl::numerics {
namespace {

struct FftwFree {
  void operator()(void* p) const { fftw_free(p); }
};
struct PlanFree {
  void operator()(fftw_plan_s* p) const { fftw_destroy_plan(p); }
};

template <class T>
std::unique_ptr<T, FftwFree> fftw_array(std::size_t n) {
  auto* p = static_cast<T*>(fftw_malloc(sizeof(T) * n));
  if (p == nullptr) throw std::bad_alloc();
  return std::unique_ptr<T, FftwFree>(p);
}

}  // namespace

struct RealFft::Impl {
  std::unique_ptr<double, FftwFree> signal;
  std::unique_ptr<fftw_complex, FftwFree> spectrum;
  std::unique_ptr<fftw_plan_s, PlanFree> forward;
  std::unique_ptr<fftw_plan_s, PlanFree> inverse;
};

RealFft::RealFft(std::size_t n) : n_(n), impl_(std::make_unique<Impl>()) {
  AMCTL_CHECK(n >= 1 && n <= static_cast<std::size_t>(1) << 30, "FFT length out of range");
  impl_->signal = fftw_array<double>(n);
  impl_->spectrum = fftw_array<fftw_complex>(n / 2 + 1);
  std::fill(impl_->signal.get(), impl_->signal.get() + n, 0.0);
  // FFTW_ESTIMATE: the plan (and so every bit of the result) does not depend on timing, and
  // making it leaves the buffers alone.
  impl_->forward.reset(fftw_plan_dft_r2c_1d(static_cast<int>(n), impl_->signal.get(),
                                            impl_->spectrum.get(), FFTW_ESTIMATE));
  impl_->inverse.reset(fftw_plan_dft_c2r_1d(static_cast<int>(n), impl_->spectrum.get(),
                                            impl_->signal.get(), FFTW_ESTIMATE));
  AMCTL_CHECK(impl_->forward != nullptr && impl_->inverse != nullptr, "fftw plan failed");
}

RealFft::~RealFft() = default;
RealFft::RealFft(RealFft&&) noexcept = default;
RealFft& RealFft::operator=(RealFft&&) noexcept = default;

std::span<double> RealFft::signal() { return {impl_->signal.get(), n_}; }

std::span<std::complex<double>> RealFft::spectrum() {
  // fftw_complex is double[2], laid out as std::complex<double> (the FFTW manual, "Complex
  // numbers"; the C++ standard, [complex.numbers]).
  return {reinterpret_cast<std::complex<double>*>(impl_->spectrum.get()), bins()};
}

void RealFft::forward() { fftw_execute(impl_->forward.get()); }

void RealFft::inverse() { fftw_execute(impl_->inverse.get()); }

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

std::vector<double> kaiser_window(std::size_t m, double beta) {
  std::vector<double> w(m, 1.0);
  if (m <= 1) return w;
  const double alpha = (static_cast<double>(m) - 1.0) / 2.0;
  const double denom = bessel_i0(beta);
  for (std::size_t n = 0; n < m; ++n) {
    const double r = (static_cast<double>(n) - alpha) / alpha;
    w[n] = bessel_i0(beta * std::sqrt(std::max(0.0, 1.0 - r * r))) / denom;
  }
  return w;
}

WelchSegments::WelchSegments(std::size_t m, std::vector<double> window)
    : fft_(m), window_(std::move(window)) {
  AMCTL_CHECK(window_.size() == m, "Welch window length differs from the segment length");
  for (const double w : window_) window_energy_ += w * w;
}

std::size_t WelchSegments::segments_in(std::size_t n) const {
  const std::size_t m = fft_.size();
  if (n < m) return 0;
  return (n - m / 2) / step();
}

std::span<const std::complex<double>> WelchSegments::transform(const double* first) {
  const std::size_t m = fft_.size();
  double mean = 0.0;
  for (std::size_t i = 0; i < m; ++i) mean += first[i];
  mean /= static_cast<double>(m);
  const std::span<double> s = fft_.signal();
  for (std::size_t i = 0; i < m; ++i) s[i] = window_[i] * (first[i] - mean);
  fft_.forward();
  return fft_.spectrum();
}

}  // namespace amctl::numerics
