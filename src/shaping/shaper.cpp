// The impulse trains (docs/shaping.md derives each one).
#include "amctl/shaping/shaper.hpp"

#include <array>
#include <cmath>
#include <numbers>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::shaping {
namespace {

constexpr double kPi = std::numbers::pi;

/// sqrt(1 - zeta^2), K = exp(-zeta pi / d) and the damped period t_d = 1 / (f d).
struct Damped {
  double d;
  double K;
  double t_d_s;
};

Damped damped(double freq_hz, double zeta) {
  const double d = std::sqrt(1.0 - zeta * zeta);
  return {d, std::exp(-zeta * kPi / d), 1.0 / (freq_hz * d)};
}

/// n impulses at i t_d / 2 with binomial amplitudes C(n-1, i) K^i: ZV (n=2), ZVD (3),
/// ZVDD (4), ZVDDD (5): the ZV shaper convolved with itself n-2 times.
void binomial(const Damped& dm, int n, Shaper& s) {
  double c = 1.0;  // C(n-1, i)
  double Ki = 1.0;
  for (int i = 0; i < n; ++i) {
    s.amplitudes.push_back(c * Ki);
    s.times_s.push_back(i == 0 ? 0.0 : 0.5 * i * dm.t_d_s);
    c = c * (n - 1 - i) / (i + 1);
    Ki *= dm.K;
  }
}

/// Solves S x = b (S symmetric positive semi-definite, n x n) by Gaussian elimination with
/// partial pivoting that eliminates the columns from the last to the first, then forward
/// substitution: the order of Klipper's mathutil.gaussian_solve, so that the same systems are
/// refused (a pivot below 1e-10 in absolute value) and the same doubles come out. Returns
/// false when refused.
bool solve_last_column_first(std::vector<std::vector<double>> S, std::vector<double> b,
                             std::vector<double>& x) {
  const std::size_t n = S.size();
  for (std::size_t i = n; i-- > 0;) {
    std::size_t p = 0;  // first row (of 0..i) with the largest |S[row][i]|
    for (std::size_t r = 1; r <= i; ++r) {
      if (std::abs(S[r][i]) > std::abs(S[p][i])) p = r;
    }
    std::swap(S[i], S[p]);
    std::swap(b[i], b[p]);
    if (std::abs(S[i][i]) < 1e-10) return false;
    const double recip = 1.0 / S[i][i];
    for (std::size_t k = 0; k < i; ++k) S[i][k] *= recip;
    b[i] *= recip;
    for (std::size_t r = 0; r < i; ++r) {
      const double c = S[r][i];
      for (std::size_t k = 0; k < i; ++k) S[r][k] -= c * S[i][k];
      b[r] -= c * b[i];
    }
  }
  // Row i now reads x_i + sum_{k<i} S[i][k] x_k = b_i.
  x = b;
  for (std::size_t i = 1; i < n; ++i) {
    double dot = 0.0;
    for (std::size_t k = 0; k < i; ++k) dot += S[i][k] * x[k];
    x[i] -= dot;
  }
  return true;
}

/// Klipper's generalised MZV: n equally spaced impulses over t damped periods whose
/// undamped amplitudes sum to 1 and put zeros of the shaper's response at the frequencies
/// (1 + i / tau) f, i = 0..n-2, tau = t (n-2) / (n-2t-1). Solved in the least-squares sense
/// (normal equations M^T M a = M^T e_0) as Klipper does; the system is consistent, so this is
/// its solution.
void mzv(const ShaperSpec& spec, const Damped& dm, double zeta, Shaper& s) {
  const int n = spec.mzv_n;
  const double t = spec.mzv_t;
  const double tau = t * (n - 2.0) / (n - 2.0 * t - 1.0);
  const auto un = static_cast<std::size_t>(n);
  std::vector<double> T(un);
  for (int j = 0; j < n; ++j) T[static_cast<std::size_t>(j)] = j * t / (n - 1.0);
  // Columns of M (one per impulse): 1, then cos and sin of each zero's phase.
  std::vector<std::vector<double>> col(un);
  for (std::size_t j = 0; j < un; ++j) {
    col[j].push_back(1.0);
    for (int i = 0; i < n - 1; ++i) {
      const double w = 2.0 * kPi * (1.0 + i / tau) * T[j];
      col[j].push_back(std::cos(w));
      col[j].push_back(std::sin(w));
    }
  }
  std::vector<std::vector<double>> MtM(un, std::vector<double>(un, 0.0));
  for (std::size_t i = 0; i < un; ++i) {
    for (std::size_t j = 0; j < un; ++j) {
      double sum = 0.0;
      for (std::size_t r = 0; r < col[i].size(); ++r) sum += col[i][r] * col[j][r];
      MtM[i][j] = sum;
    }
  }
  std::vector<double> A;
  if (!solve_last_column_first(MtM, std::vector<double>(un, 1.0), A)) {  // M^T e_0 = ones
    throw Error(fmt::format("type mzv(n={}, t={}): ill-formed shaper (singular system)", n, t));
  }
  for (std::size_t j = 0; j < un; ++j) {
    if (A[j] < -1e-5) {
      throw Error(fmt::format("type mzv(n={}, t={}): negative-valued shaper (amplitude {} = {})",
                              n, t, j, A[j]));
    }
  }
  // Damping: impulse j is j t / (n-1) damped periods late, so it is scaled by K_step^j with
  // K_step = exp(-2 t zeta pi / ((n-1) d)) (K^(2t/(n-1)) in the notation of shaper.hpp).
  const double K = std::exp(-2.0 * t * zeta * kPi / ((n - 1.0) * dm.d));
  double Kp = K;
  s.amplitudes.push_back(A[0]);
  s.times_s.push_back(T[0]);
  for (std::size_t j = 1; j < un; ++j) {
    s.amplitudes.push_back(A[j] * Kp);
    s.times_s.push_back(T[j] * dm.t_d_s);
    Kp *= K;
  }
}

/// Klipper's EI: amplitudes and middle time as polynomials in zeta (and v_tol).
void ei(double v, double dr, const Damped& dm, Shaper& s) {
  const double a1 = (0.24968 + 0.24961 * v) +
                    ((0.80008 + 1.23328 * v) + (0.49599 + 3.17316 * v) * dr) * dr;
  const double a3 = (0.25149 + 0.21474 * v) +
                    ((-0.83249 + 1.41498 * v) + (0.85181 - 4.90094 * v) * dr) * dr;
  const double a2 = 1.0 - a1 - a3;
  const double t2 = 0.4999 + (((0.46159 + 8.57843 * v) * v) +
                              (((4.26169 - 108.644 * v) * v) +
                               ((1.75601 + 336.989 * v) * v) * dr) * dr) * dr;
  s.amplitudes = {a1, a2, a3};
  s.times_s = {0.0, t2 * dm.t_d_s, dm.t_d_s};
}

/// Impulse i: time (sum_k t[i][k] zeta^k) / f and amplitude sum_k a[i][k] zeta^k, the
/// curve fits Klipper tabulates for the 2- and 3-hump EI shapers (V_tol = 5 %).
template <std::size_t N>
void hump_ei(const std::array<std::array<double, 4>, N>& tc,
             const std::array<std::array<double, 4>, N>& ac, double freq_hz, double zeta,
             Shaper& s) {
  const double period_s = 1.0 / freq_hz;
  for (std::size_t i = 0; i < N; ++i) {
    double u = tc[i][3];
    double v = ac[i][3];
    for (int k = 2; k >= 0; --k) {
      u = u * zeta + tc[i][static_cast<std::size_t>(k)];
      v = v * zeta + ac[i][static_cast<std::size_t>(k)];
    }
    s.times_s.push_back(u * period_s);
    s.amplitudes.push_back(v);
  }
}

// Coefficients of 1, zeta, zeta^2, zeta^3 (Klipper shaper_defs.py, get_2hump_ei_shaper and
// get_3hump_ei_shaper): times in undamped periods 1/f, amplitudes.
constexpr std::array<std::array<double, 4>, 4> k2HumpT = {{{0., 0., 0., 0.},
                                                           {0.49890, 0.16270, -0.54262, 6.16180},
                                                           {0.99748, 0.18382, -1.58270, 8.17120},
                                                           {1.49920, -0.09297, -0.28338, 1.85710}}};
constexpr std::array<std::array<double, 4>, 4> k2HumpA = {{{0.16054, 0.76699, 2.26560, -1.22750},
                                                           {0.33911, 0.45081, -2.58080, 1.73650},
                                                           {0.34089, -0.61533, -0.68765, 0.42261},
                                                           {0.15997, -0.60246, 1.00280, -0.93145}}};
constexpr std::array<std::array<double, 4>, 5> k3HumpT = {{{0., 0., 0., 0.},
                                                           {0.49974, 0.23834, 0.44559, 12.4720},
                                                           {0.99849, 0.29808, -2.36460, 23.3990},
                                                           {1.49870, 0.10306, -2.01390, 17.0320},
                                                           {1.99960, -0.28231, 0.61536, 5.40450}}};
constexpr std::array<std::array<double, 4>, 5> k3HumpA = {{{0.11275, 0.76632, 3.29160, -1.44380},
                                                           {0.23698, 0.61164, -2.57850, 4.85220},
                                                           {0.30008, -0.19062, -2.14560, 0.13744},
                                                           {0.23775, -0.73297, 0.46885, -2.08650},
                                                           {0.11244, -0.45439, 0.96382, -1.46000}}};

/// Marlin FT_MOTION (ft_motion/shaping.cpp, set_axis_shaping_A and _N): impulse i at i * base
/// damped periods (base 1/2, or 3/8 for MZV), rounded to whole samples of sample_rate_hz when it
/// is > 0 (Marlin rounds the first echo's delay, N1 = round(base t_d FS), and places echo i at
/// i N1); amplitudes as Marlin writes them before dividing by their sum.
void marlin(const ShaperSpec& spec, const Damped& dm, Shaper& s) {
  const double K = dm.K;
  const double K2 = K * K;
  const double V = spec.ei_v_tol;
  double base = 0.5;
  switch (spec.type) {
    case ShaperType::zv: s.amplitudes = {1.0, K}; break;
    case ShaperType::zvd: s.amplitudes = {1.0, 2.0 * K, K2}; break;
    case ShaperType::zvdd: s.amplitudes = {1.0, 3.0 * K, 3.0 * K2, K2 * K}; break;
    case ShaperType::zvddd: s.amplitudes = {1.0, 4.0 * K, 6.0 * K2, 4.0 * K2 * K, K2 * K2}; break;
    case ShaperType::ei:
      // The undamped EI [(1+V)/4, (1-V)/2, (1+V)/4], impulse i scaled by K^i.
      s.amplitudes = {0.25 * (1.0 + V), 0.5 * (1.0 - V) * K, 0.25 * (1.0 + V) * K2};
      break;
    case ShaperType::two_hump_ei: {
      const double v2 = V * V;
      const double X = std::cbrt(v2 * (std::sqrt(1.0 - v2) + 1.0));
      const double a0 = (3.0 * X * X + 2.0 * X + 3.0 * v2) / (16.0 * X);
      s.amplitudes = {a0, (0.5 - a0) * K, (0.5 - a0) * K2, a0 * K2 * K};
      break;
    }
    case ShaperType::three_hump_ei: {
      const double a0 = (1.0 + 3.0 * V + 2.0 * std::sqrt(2.0 * (V + 1.0) * V)) / 16.0;
      const double a1 = 0.25 * (1.0 - V);
      s.amplitudes = {a0, a1 * K, (0.5 * (1.0 + V) - 2.0 * a0) * K2, a1 * K2 * K, a0 * K2 * K2};
      break;
    }
    case ShaperType::mzv:
      // Phases 0, 3pi/4, 3pi/2 as Klipper's, but each impulse decayed by K (half a damped
      // period's decay) where the mode decays by K^(3/4) over 3/8 of a period.
      s.amplitudes = {1.0, std::numbers::sqrt2 * K, K2};
      base = 0.375;
      break;
  }
  double step_s = base * dm.t_d_s;
  if (spec.sample_rate_hz > 0.0) {
    const double samples = std::round(step_s * spec.sample_rate_hz);
    if (samples < 1.0) {
      // round(base t_d FS) >= 1 needs base t_d FS >= 0.5, t_d = 1 / (f sqrt(1 - zeta^2)).
      throw Error(fmt::format("freq_hz: found {:g} Hz, which puts Marlin's first echo {:.3g} ms late, "
                              "under one sample of its {:g} Hz trajectory rate; expected at most {:.6g} Hz",
                              s.freq_hz, step_s * 1e3, spec.sample_rate_hz,
                              2.0 * base * spec.sample_rate_hz / dm.d));
    }
    step_s = samples / spec.sample_rate_hz;
  }
  for (std::size_t i = 0; i < s.amplitudes.size(); ++i) s.times_s.push_back(static_cast<double>(i) * step_s);
}

}  // namespace

void require_damping_ratio(std::string_view what, double zeta) {
  if (!std::isfinite(zeta) || zeta < 0.0 || zeta >= 1.0) {
    throw Error(fmt::format("{} must be a finite number in [0, 1), got {}", what, zeta));
  }
}

double Shaper::duration_s() const { return times_s.empty() ? 0.0 : times_s.back() - times_s.front(); }

double Shaper::amplitude_sum() const {
  double sum = 0.0;
  for (double a : amplitudes) sum += a;
  return sum;
}

std::vector<double> Shaper::normalized_amplitudes() const {
  const double inv = 1.0 / amplitude_sum();
  std::vector<double> out(amplitudes);
  for (double& a : out) a *= inv;
  return out;
}

double Shaper::time_shift_s() const {
  double ts = 0.0;
  for (std::size_t i = 0; i < amplitudes.size(); ++i) ts += amplitudes[i] * times_s[i];
  return ts / amplitude_sum();
}

Shaper make_shaper(const ShaperSpec& spec, double freq_hz, double damping_ratio) {
  require_positive("freq_hz", freq_hz);
  require_damping_ratio("damping_ratio", damping_ratio);
  Shaper s;
  s.spec = spec;
  s.freq_hz = freq_hz;
  s.damping_ratio = damping_ratio;
  const Damped dm = damped(freq_hz, damping_ratio);
  if (spec.firmware == Firmware::marlin) {
    if (spec.type == ShaperType::mzv && (spec.mzv_n != 3 || spec.mzv_t != 0.75)) {
      throw Error("type: Marlin's mzv takes no parameters (mzv(n, t) is Klipper's generalisation)");
    }
    marlin(spec, dm, s);
    return s;
  }
  if ((spec.type == ShaperType::two_hump_ei || spec.type == ShaperType::three_hump_ei) &&
      spec.ei_v_tol != 0.05) {
    throw Error(fmt::format("type {}: Klipper's multi-hump EI shapers are fitted for v_tol = 0.05 "
                            "only (Marlin's take v_tol)", to_string(spec)));
  }
  switch (spec.type) {
    case ShaperType::zv: binomial(dm, 2, s); break;
    case ShaperType::zvd: binomial(dm, 3, s); break;
    case ShaperType::zvdd: binomial(dm, 4, s); break;
    case ShaperType::zvddd: binomial(dm, 5, s); break;
    case ShaperType::mzv: mzv(spec, dm, damping_ratio, s); break;
    case ShaperType::ei: ei(spec.ei_v_tol, damping_ratio, dm, s); break;
    case ShaperType::two_hump_ei: hump_ei(k2HumpT, k2HumpA, freq_hz, damping_ratio, s); break;
    case ShaperType::three_hump_ei: hump_ei(k3HumpT, k3HumpA, freq_hz, damping_ratio, s); break;
  }
  AMCTL_CHECK(!s.amplitudes.empty() && s.amplitudes.size() == s.times_s.size(),
              "a shaper has one time per amplitude");
  return s;
}

Shaper make_shaper(std::string_view type, double freq_hz, double damping_ratio) {
  return make_shaper(parse_shaper_spec(type), freq_hz, damping_ratio);
}

}  // namespace amctl::shaping
