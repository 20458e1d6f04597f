#pragma once
// Klipper-compatible input-shaper calibration (klippy/extras/shaper_calibrate.py; the
// equations and the commit they were checked against are in docs/resonance.md):
//   1. Welch PSD of each axis: segments of M = 2^ceil(log2(fs * 0.5)) samples (fs = samples /
//      duration), half overlapping, each detrended (mean removed) and Kaiser-windowed
//      (beta 6), |rfft|^2 / (fs sum w^2), doubled except at DC and Nyquist, averaged.
//   2. Normalisation: psd / (f + 0.1), and below 10 Hz times exp(1 - (10 / (f + 0.1))^2).
//   3. For each shaper (zv, mzv, ei, 2hump_ei, 3hump_ei) over the frequencies from its
//      minimum to 150 Hz in 0.2 Hz steps (numpy.arange's grid), the remaining vibrations of
//      psd_xyz (f <= 200 Hz) pessimised over test damping ratios 0.075, 0.1, 0.15, the
//      smoothing, the score smoothing (v^1.5 + 0.2 v + 0.01), the max accel; the frequency
//      with the fewest vibrations, then the one with the lowest score within 1.1 v_best +
//      0.0005; then Klipper's rule across shapers.
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/core/output.hpp"
#include "amctl/resonance/record.hpp"
#include "amctl/resonance/sweep.hpp"

namespace amctl::resonance {

/// Klipper's constants (shaper_calibrate.py).
inline constexpr double kKlipperWindowS = 0.5;
inline constexpr double kKlipperMinFreqHz = 5.0;
inline constexpr double kKlipperMaxFreqHz = 200.0;
inline constexpr double kKlipperMaxShaperFreqHz = 150.0;
inline constexpr double kKlipperShaperFreqStepHz = 0.2;
inline constexpr double kKlipperKaiserBeta = 6.0;
inline constexpr double kKlipperVibrationReduction = 20.0;  ///< shaper_defs.py

/// Klipper's Welch segment length for a sample rate: the power of two
/// 1 << bit_length(int(fs * 0.5 - 1)) (1 when fs * 0.5 < 2).
[[nodiscard]] std::size_t klipper_segment_samples(double sample_rate_hz);

/// A Welch PSD with the parameters it was made with.
struct WelchPsd {
  PsdTable table;
  double sample_rate_hz = 0.0;      ///< samples / duration (Klipper's)
  std::size_t segment_samples = 0;  ///< M
  std::size_t segments = 0;
};

/// Klipper's Welch PSD of a record (unnormalised). Throws amctl::Error naming the record's
/// source when it has no more samples than one segment.
[[nodiscard]] WelchPsd klipper_psd(const AccelRecord& record);

/// Klipper's normalize_to_frequencies, in place (no-op when already normalised).
void normalize_to_frequencies(PsdTable& psd);

/// One shaper at one frequency as Klipper's fit scores it.
struct ShaperFit {
  std::string name;
  double freq_hz = 0.0;
  double vibrations = 0.0;  ///< fraction of the PSD's vibrations left (pessimised)
  double smoothing_mm = 0.0;
  double score = 0.0;
  double max_accel_mm_s2 = 0.0;
};

struct KlipperOptions {
  std::vector<std::string> shapers{"zv", "mzv", "ei", "2hump_ei", "3hump_ei"};
  double damping_ratio = 0.1;  ///< the shapers' design damping ratio
  double scv_mm_s = 5.0;
  std::vector<double> test_damping_ratios{0.075, 0.1, 0.15};
  double max_freq_hz = kKlipperMaxFreqHz;
  std::optional<double> max_smoothing_mm;
  std::optional<double> max_vibrations;  ///< fraction
};

struct KlipperCalibration {
  std::vector<ShaperFit> shapers;  ///< the pick for each shaper, in the order tried
  ShaperFit recommended;
};

/// Klipper's fit of every shaper and its recommendation on a normalised PSD.
/// Throws amctl::Error for an unknown shaper name or a PSD table that is not normalised.
[[nodiscard]] KlipperCalibration klipper_calibrate(const PsdTable& normalized_psd,
                                                   const KlipperOptions& options = {});

/// The same fit over several records (calibrate_shaper.py A.csv B.csv since Klipper's rework
/// of October 2025): each record keeps its own PSD, and at every test frequency a shaper's
/// remaining vibrations are the worst over the records (and the test damping ratios).
[[nodiscard]] KlipperCalibration klipper_calibrate(const std::vector<PsdTable>& normalized_psds,
                                                   const KlipperOptions& options = {});

/// What `amctl resonance calibrate FILE --axis x|y` does.
struct CalibrateOptions {
  char axis = 'x';  ///< 'x' or 'y': the axis the record excited (the fit, like Klipper's
                    ///< calibrate_shaper.py, uses psd_xyz; the axis picks the peak reported);
                    ///< 0: not said (as calibrate_shaper.py, which has no axis): no axis peak
  KlipperOptions klipper;
  /// The commanded sweep, when known: adds the frequency response and the modal fit
  /// (identify_sweep; time records only).
  std::optional<SweepExcitation> sweep;
  /// With a sweep: the number of modes fitted (1..kMaxModes), 0 to choose it by BIC.
  int modes = 0;
};

/// Why Klipper's rule may be biased on this record, and what it picks once the bias is taken
/// out. Klipper's shaper rule is tuned on its own test: pulses of accel_per_hz * f, so the
/// excitation's PSD grows as f^2 (then divided by f + 0.1 in normalize_to_frequencies). A
/// constant-amplitude sweep has a flat excitation: against Klipper's, every frequency f is
/// weighted (f_ref / f)^2 more, the low frequencies (where the measured acceleration is mostly
/// the commanded motion itself) dominate, and the rule picks a low shaper frequency. With the
/// sweep known the record's PSD is reweighted by f^2 (the excitation ratio; the rule is
/// scale-free) and the rule rerun: what Klipper would pick had it excited the axis itself.
struct ExcitationCaveat {
  /// "constant_amplitude_sweep" (a --sweep was given) or "unknown" (a foreign format without
  /// --sweep: the corpus CSV).
  std::string excitation;
  std::string why;  ///< one paragraph, for the text report and the JSON
  /// Klipper's rule on the PSD reweighted to Klipper's excitation (with a sweep only).
  std::optional<KlipperCalibration> reweighted;
};

struct CalibrationReport {
  std::string source;
  /// Every record of the fit, the first one's name first (several files, or the columns of a
  /// several-record PSD file); the fields below describe the first record.
  std::vector<std::string> sources;
  RecordFormat format = RecordFormat::corpus;
  char axis = 'x';
  std::optional<RecordQuality> quality;  ///< for time records
  std::optional<WelchPsd> welch;         ///< for time records: the unnormalised PSD
  PsdTable psd;                          ///< normalised (what the fit used)
  double peak_axis_hz = 0.0;             ///< the normalised PSD's peak on `axis`
  double peak_xyz_hz = 0.0;              ///< the normalised psd_xyz's peak (f <= max freq)
  KlipperCalibration klipper;
  std::optional<SweepIdentification> identification;  ///< with CalibrateOptions::sweep
  /// When the record was not excited as Klipper excites (a --sweep, or a foreign format):
  /// why Klipper's rule is biased there and its pick on the reweighted PSD.
  std::optional<ExcitationCaveat> caveat;
};

/// Reads the file and calibrates. Throws amctl::Error on bad input or options.
[[nodiscard]] CalibrationReport calibrate_file(const std::string& path,
                                               const CalibrateOptions& options);
/// Several files at once, as `calibrate_shaper.py A.csv B.csv`: every record (a raw record,
/// a PSD file, each column of a several-record PSD file) joins the fit (klipper_calibrate over
/// a list). The report's record fields are the first file's. --sweep takes one record.
[[nodiscard]] CalibrationReport calibrate_files(const std::vector<std::string>& paths,
                                                const CalibrateOptions& options);
/// Same on a file already read.
[[nodiscard]] CalibrationReport calibrate(const AccelFile& file, const std::string& source,
                                          const CalibrateOptions& options);

/// JSON keys (an interface): source, format, axis, sample_rate_hz, jitter, gaps, clipping,
/// record{...}, psd{segment_samples, segments, bin_hz, peak_axis_hz, peak_xyz_hz},
/// klipper{recommended{name, freq_hz}, shapers[{name, freq_hz, vibrations, smoothing,
/// max_accel_mm_s2, score}]}; with a sweep, model{natural_frequency_hz,
/// natural_frequency_std_hz, damping_ratio, damping_ratio_std, gain, gain_std,
/// rms_residual, bins_used, sweep_start_s, alignment_peak, segment_samples, mode_count,
/// mode_selection (asked|bic), bic[], dominant_mode, modes[{natural_frequency_hz,
/// natural_frequency_std_hz, damping_ratio, damping_ratio_std, gain, gain_std, peak_gain}]};
/// when the record was not excited as Klipper excites, excitation_caveat{excitation, why,
/// klipper_rule_on_reweighted_psd{name, freq_hz} (null without a sweep)}.
[[nodiscard]] Json to_json(const CalibrationReport& report);
[[nodiscard]] std::string to_text(const CalibrationReport& report);

/// Writes the unnormalised PSD (the Welch PSD of a record, or the table read from a PSD file)
/// as Klipper's `freq,psd_x,psd_y,psd_z,psd_xyz` CSV with round-trip precision, through
/// amctl::OutputFile (a regular file whole or not at all; "-", a device or a FIFO streamed).
/// Throws amctl::Error naming the path when it cannot be written, or when the report only
/// holds a normalised table.
void write_psd_csv(const CalibrationReport& report, const std::string& path,
                   const OutputOptions& options = {});

/// Writes the measured frequency response of a --sweep identification as CSV
/// `freq_hz,gain,phase_rad,coherence,used,model_gain`, whole or not at all
/// (as write_psd_csv). Throws amctl::Error when the report has no identification.
void write_response_csv(const CalibrationReport& report, const std::string& path,
                        const OutputOptions& options = {});

}  // namespace amctl::resonance
