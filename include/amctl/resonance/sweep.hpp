#pragma once
// Identification with the excitation known (docs/resonance.md, section 6): a linear sine
// sweep of the commanded acceleration,
//   u(t) = A sin(2 pi (F0 (t - t0) + RATE (t - t0)^2 / 2)),  0 <= t - t0 <= (F1 - F0) / RATE,
// is located in the record (t0, and the time scale k of the record's clock against the sweep's),
// the frequency response H1 = S_uy / S_uu and its coherence
// are estimated with Welch cross-spectra, and one mode driven through its base,
//   |H(f)| = g |2 zeta w s + w^2| / |s^2 + 2 zeta w s + w^2|   (or g w^2 / |...|), s = i 2 pi f,
// is fitted to |H1| (log gain, weighted by coherence) by Levenberg-Marquardt from the best
// point of a grid, with uncertainties. The phase is not fitted: it also holds what the
// alignment leaves (a delay that grows with frequency when the time scale is slightly off).
#include <string>
#include <string_view>
#include <vector>

#include "amctl/resonance/record.hpp"

namespace amctl::resonance {

struct SweepExcitation {
  double f0_hz = 0.0;
  double f1_hz = 0.0;
  double rate_hz_s = 0.0;
  double accel_mm_s2 = 0.0;
};

/// Parses "F0,F1,RATE,ACCEL" (Hz, Hz, Hz/s, mm/s^2). Throws amctl::Error naming `sweep`.
[[nodiscard]] SweepExcitation parse_sweep(std::string_view text);

/// One bin of the measured frequency response.
struct ResponseBin {
  double freq_hz = 0.0;
  double gain = 0.0;       ///< |H1|
  double phase_rad = 0.0;  ///< arg H1
  double coherence = 0.0;  ///< gamma^2 in [0, 1]
  bool used = false;       ///< in the fit
};

/// Where the mode's damping acts: between the carriage and what drives it (a belt's own
/// damping: H = g (2 zeta w s + w^2) / (s^2 + 2 zeta w s + w^2), which falls as 1/f above the
/// mode), or on the carriage's absolute motion (friction, a damper to the frame:
/// H = g w^2 / (s^2 + 2 zeta w s + w^2), which falls as 1/f^2). Both are fitted; the one with
/// the smaller weighted residual is kept.
enum class ModeKind { base_damped, ground_damped };
[[nodiscard]] std::string_view to_string(ModeKind kind);

/// One mode of a fit with several: H(f) = sum_i g_i h_i(f), h_i the unit-gain form of its
/// kind (all modes of a fit share the kind); |H| is what is fitted.
struct ModeEstimate {
  double natural_frequency_hz = 0.0;
  double natural_frequency_std_hz = 0.0;
  double damping_ratio = 0.0;
  double damping_ratio_std = 0.0;
  double gain = 0.0;  ///< g_i > 0
  double gain_std = 0.0;
  double peak_gain = 0.0;  ///< max over f of g_i |h_i(f)|: what makes a mode the dominant one
};

/// How the number of modes was chosen: asked (`--modes N`) or by the Bayesian information
/// criterion BIC(N) = n ln(RSS_N / n) + 3 N ln n over N = 1..3 (n bins, RSS_N the weighted
/// residual sum of squares of the N-mode fit), the smallest BIC.
enum class ModeSelection { asked, bic };
[[nodiscard]] std::string_view to_string(ModeSelection selection);

/// The natural frequency, damping ratio and gain (and their uncertainties) are the dominant
/// mode's (the largest peak gain); with one mode they are the one-mode fit's.
struct ModalFit {
  ModeKind kind = ModeKind::base_damped;
  double natural_frequency_hz = 0.0;
  double natural_frequency_std_hz = 0.0;
  double damping_ratio = 0.0;
  double damping_ratio_std = 0.0;
  double gain = 0.0;  ///< g > 0: the static gain (1 for a rigid axis)
  double gain_std = 0.0;
  double rms_residual = 0.0;  ///< weighted log-gain residual per degree of freedom
  std::size_t bins_used = 0;
  int iterations = 0;
  std::vector<ModeEstimate> modes;  ///< every mode, by natural frequency (one with N = 1)
  std::size_t dominant_mode = 0;    ///< index in `modes`
  ModeSelection selection = ModeSelection::bic;
  std::vector<double> bic;          ///< BIC(N) for N = 1, 2, ... (those fitted)
};

/// Largest number of modes fitted (`--modes` and the automatic choice).
inline constexpr int kMaxModes = 3;

struct SweepIdentification {
  SweepExcitation sweep;
  double sweep_start_s = 0.0;   ///< t0 on the record's time axis
  double alignment_peak = 0.0;  ///< normalised correlation at t0 (1: the record is the chirp)
  /// k: the record holds the chirp at k (t - t0), i.e. its frequencies appear divided by k
  /// (a sample clock, or a sweep rate, off by 1/k - 1). 0.95 to 1.05 searched, to 0.001.
  double time_scale = 1.0;
  std::size_t segment_samples = 0;
  std::vector<ResponseBin> response;
  ModalFit model;
};

/// The fitted model's gain |H(f)| (the sum of every mode).
[[nodiscard]] double model_gain(const ModalFit& fit, double freq_hz);

/// Identifies the modes on `axis` ('x' or 'y'): `mode_count` modes (1..kMaxModes), or 0 to
/// choose 1..kMaxModes by BIC. Throws amctl::Error naming the record when the sweep does not
/// fit in it, exceeds the Nyquist frequency, or leaves too few coherent bins, and naming
/// `--modes` when mode_count is outside 0..kMaxModes.
[[nodiscard]] SweepIdentification identify_sweep(const AccelRecord& record, char axis,
                                                 const SweepExcitation& sweep, int mode_count = 0);

}  // namespace amctl::resonance
