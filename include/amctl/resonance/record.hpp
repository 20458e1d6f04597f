#pragma once
// Accelerometer records as Klipper and the corpus write them (docs/resonance.md):
//   - Klipper's raw CSV           `#time,accel_x,accel_y,accel_z`                 (s, mm/s^2)
//   - the corpus CSV              `#time_s,accel_x_mm_s2,accel_y_mm_s2,accel_z_mm_s2`
//   - Klipper's PSD CSV           `freq,psd_x,psd_y,psd_z,psd_xyz` (unnormalised Welch PSD, as
//     TEST_RESONANCES writes it; with a trailing `,shapers:,...` it is the normalised PSD that
//     calibrate_shaper.py --csv writes, and is read as such; the older calibration_data_*.csv
//     of SHAPER_CALIBRATE, with one column per shaper after psd_xyz (`zv(41.6),mzv(25.6),...`),
//     is normalised too, as the Klipper that wrote them read them)
//   - Klipper's PSD CSV of several records, `freq,NAME1,NAME2,...[,shapers:,...]` (what
//     calibrate_shaper.py --csv writes for A.csv B.csv): one psd_xyz column per record
// Bad input throws amctl::Error "FILE:LINE: what was found, expected what"; an empty or
// binary file throws an error naming the file.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::resonance {

/// Which of the formats above a file is in.
enum class RecordFormat { klipper_raw, corpus, klipper_psd };

[[nodiscard]] std::string_view to_string(RecordFormat format);

/// A time series of 3-axis acceleration. Times strictly increase.
struct AccelRecord {
  std::string source;  ///< the file name (for messages)
  std::vector<double> time_s;
  std::vector<double> accel_x_mm_s2;
  std::vector<double> accel_y_mm_s2;
  std::vector<double> accel_z_mm_s2;

  [[nodiscard]] std::size_t size() const { return time_s.size(); }
};

/// A power spectral density per axis over frequency bins [(mm/s^2)^2 / Hz].
struct PsdTable {
  std::vector<double> freq_hz;
  std::vector<double> psd_x;
  std::vector<double> psd_y;
  std::vector<double> psd_z;
  std::vector<double> psd_xyz;  ///< psd_x + psd_y + psd_z (as read, for a PSD file)
  /// true when already divided by (f + 0.1) and damped below 10 Hz (Klipper's
  /// normalize_to_frequencies); a `,shapers:` PSD file is.
  bool normalized = false;
  /// A column of a several-record PSD file: the record's name; psd_x, psd_y and psd_z are then
  /// empty (Klipper does not store them there).
  std::string name;
};

/// Clipping on one axis: runs of at least kClipRunSamples consecutive samples at exactly the
/// axis's minimum or maximum value (a saturated sensor repeats its extreme reading).
struct AxisClipping {
  double min_mm_s2 = 0.0;
  double max_mm_s2 = 0.0;
  std::size_t runs = 0;     ///< runs at the minimum or the maximum
  std::size_t samples = 0;  ///< samples in those runs
};

inline constexpr std::size_t kClipRunSamples = 3;
/// An interval longer than this many median intervals is a gap.
inline constexpr double kGapFactor = 1.5;

/// What the time base and the values of a record look like.
struct RecordQuality {
  std::size_t samples = 0;
  double duration_s = 0.0;          ///< last time - first time
  double median_interval_s = 0.0;
  double sample_rate_hz = 0.0;      ///< 1 / median interval
  double mean_sample_rate_hz = 0.0; ///< samples / duration: the rate Klipper's PSD uses
  /// Relative spread of the intervals: RMS deviation of the non-gap intervals from the median
  /// interval, divided by the median interval.
  double jitter = 0.0;
  double max_interval_deviation = 0.0;  ///< largest |interval - median| / median, gaps excluded
  std::size_t gaps = 0;                 ///< intervals > kGapFactor x median
  double largest_gap_s = 0.0;           ///< the longest such interval (0 without gaps)
  double missing_s = 0.0;               ///< sum over gaps of (interval - median)
  AxisClipping clip_x;
  AxisClipping clip_y;
  AxisClipping clip_z;
};

/// What a file held: a time record or a PSD table.
struct AccelFile {
  RecordFormat format = RecordFormat::corpus;
  AccelRecord record;  ///< klipper_raw and corpus
  PsdTable psd;        ///< klipper_psd (the first record of a several-record PSD file)
  std::vector<PsdTable> more_psd;  ///< klipper_psd: the other records of a several-record file
};

/// Reads any of the formats above (told apart by the header); "-" reads standard input.
/// Throws amctl::Error.
[[nodiscard]] AccelFile read_accel_file(const std::string& path);

/// Memory a calibration takes per sample of a raw record: the record (time and three axes,
/// 32 bytes) and the intervals of the quality check (8). Measured on a 10-million-row record
/// (docs/resonance.md, "Memory").
inline constexpr std::uint64_t kRecordBytesPerSample = 40;

/// What reading a record will take, from its size and its first rows, before reading it.
struct RecordSizeEstimate {
  std::uint64_t bytes = 0;         ///< the file
  std::uint64_t samples = 0;       ///< rows, about
  std::uint64_t memory_bytes = 0;  ///< samples * kRecordBytesPerSample
};
/// None for standard input or a FIFO (no size to go by) or an empty file.
[[nodiscard]] std::optional<RecordSizeEstimate> estimate_record_size(const std::string& path);
/// Same from text already in memory; `source` names it in messages.
[[nodiscard]] AccelFile parse_accel_text(std::string_view text, const std::string& source);

/// Time base and value checks. Throws amctl::Error naming the source with fewer than 2 samples.
[[nodiscard]] RecordQuality assess_record(const AccelRecord& record);

}  // namespace amctl::resonance
