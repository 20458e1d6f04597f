#pragma once
// `amctl report`: one self-contained HTML page about a print (docs/report.md).
//
//   PlanSource(G-code, machine) -> EstimateSink   (summary, time per layer and per feature)
//                               -> SpeedLodSink   (min/max speed per time bucket, bounded)
//                               -> ToolpathSink   (decimated XY polyline per layer, bounded)
//                               -> SimulationSink (with a belt model: contour error, fed back
//                                                  into the toolpath per sample; with the
//                                                  machine's input shaper, the shaped
//                                                  simulation of `amctl simulate`)
// in one pass and bounded memory. The data goes into the page as JSON in a
// <script type="application/json"> tag; the page draws it with its own inline script
// (canvas), asks for nothing over the network (a Content-Security-Policy forbids it) and is
// written to a temporary file renamed into place: never a partial file.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/file_limits.hpp"
#include "amctl/report/toolpath.hpp"

namespace amctl::report {

struct BeltModelOptions {
  double natural_frequency_hz = 0.0;
  double damping_ratio = 0.1;
};

struct ReportOptions {
  std::optional<BeltModelOptions> belt;   ///< simulate and colour by contour error
  double sample_rate_hz = 1000.0;         ///< simulation rate (with a belt model)
  /// With a belt model: drive it with the machine's input shaper ([input_shaper], or M593
  /// before the first move), as `amctl simulate` does; false: the unshaped command.
  bool machine_shaper = true;
  bool strict = true;                     ///< false: skip malformed lines (counted)
  /// The file's own limits commands: kept as the firmware does, ignored or capped.
  plan::FileLimits file_limits = plan::FileLimits::keep;
  std::size_t speed_buckets = 4096;       ///< at most this many (at least half) in the page
  /// A second, finer level of the speed chart for zoomed views (0: none): at most this many
  /// buckets, so a view of a few minutes of a long print still has a bucket per pixel.
  std::size_t fine_speed_buckets = 32768;
  ToolpathOptions toolpath;
  /// An accelerometer record (Klipper raw or PSD CSV, or the corpus CSV): adds the resonance
  /// section (the normalised PSD, every shaper Klipper fits with its remaining-vibration
  /// curve, the recommendation and the PSD after it). Empty: none.
  std::string accel_path;
  char accel_axis = 'x';  ///< the axis the record excited
  /// "hotend" or "bed": adds the heater loop section (thermal::run_heater_study with that
  /// heater's defaults and the print's own target: the file's first non-zero temperature for
  /// that heater, the study's default when the file sets none). Empty: none.
  std::string thermal;
};

struct ReportResult {
  std::string file;
  std::string output;
  std::uint64_t bytes = 0;         ///< size of the page
  std::uint64_t moves = 0;
  std::size_t layers = 0;
  std::size_t toolpath_points = 0;
  bool toolpath_capped = false;
  std::size_t speed_buckets = 0;
  bool simulated = false;
  double compute_time_s = 0.0;     ///< planning, sinks, page, write
};

/// Everything the page shows, as the JSON embedded in it (also for tests).
[[nodiscard]] Json report_data(const std::string& path, const machine::Machine& machine,
                               const ReportOptions& options);

/// The page for `data` (report_data's form). Every '<' inside the JSON is written as
/// \u003c, so no string in it can close the script element.
[[nodiscard]] std::string render_html(const Json& data);

/// report_data + render_html, written atomically to `output_path`. Throws amctl::Error
/// (file:line:col) on bad input and when the page cannot be written.
ReportResult write_report(const std::string& path, const machine::Machine& machine,
                          const std::string& output_path, const ReportOptions& options);

/// `amctl report --json`: file, output, bytes, moves, layers, ...
[[nodiscard]] Json to_json(const ReportResult& result);

}  // namespace amctl::report
