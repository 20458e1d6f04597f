#pragma once
// A whole print through the belt dynamics, as one pipeline:
//   PlanSource(G-code, machine) -> SimulationSink (StreamingSimulation + QualityMeter)
//                               -> EstimateSink (feature names, layer times)
//                               -> ProfilePeaksSink (peak accel/jerk of the plan)
// in bounded memory, optionally writing the commanded and simulated path as CSV (written to
// a temporary file renamed into place at the end: never a partial file). This is what
// `amctl simulate` runs (docs/dynamics.md).
#include <cstddef>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/profile_peaks.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::dynamics {

/// "f_hz,damping_ratio[,participation]" -> Mode (the `simulate --mode` syntax).
[[nodiscard]] Mode parse_mode_spec(std::string_view text);

/// The simulation as a sink of the plan stream.
class SimulationSink final : public plan::Sink {
 public:
  SimulationSink(const AxisModel& model_x, const AxisModel& model_y,
                 const SimulationOptions& simulation, const MetricsOptions& metrics,
                 StreamingSimulation::RowSink rows = nullptr);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;

  [[nodiscard]] const QualityReport& report() const { return report_; }
  [[nodiscard]] const SimulationStats& stats() const { return stream_.stats(); }
  [[nodiscard]] std::size_t moves() const { return moves_; }
  [[nodiscard]] std::size_t max_window_moves() const { return stream_.max_window_moves(); }
  /// Feature names by PlannedMove::feature, for every feature a simulated move had.
  [[nodiscard]] const std::vector<std::string>& feature_names() const { return feature_names_; }

 private:
  StreamingSimulation stream_;
  QualityReport report_;
  std::size_t moves_ = 0;
  std::set<std::uint16_t> used_features_;
  std::vector<std::string> feature_names_;
};

struct PrintSimulationOptions {
  SimulationOptions simulation;
  MetricsOptions metrics;
  /// Write t, commanded and simulated path, contour error and vibration per sample here.
  std::string csv_path;
  /// CSV row rate [Hz]; must divide simulation.sample_rate_hz (default: every sample).
  std::optional<double> csv_rate_hz;
  /// Called for every simulated sample with its contour error [mm] (NaN for a sample outside
  /// the measured range), beside the CSV; may be empty. The Python binding fills its sample
  /// arrays from it. Runs on the simulating thread, in time order.
  StreamingSimulation::RowSink rows;
};

struct PrintSimulationResult {
  std::string file;
  std::string machine_name;
  std::string profile;             ///< velocity profile the plan was timed with
  AxisModel model_x, model_y;
  bool motor_space = false;
  double sample_rate_hz = 0.0;
  QualityReport report;
  SimulationStats stats;
  std::size_t moves = 0;
  std::size_t max_window_moves = 0;
  std::vector<std::string> feature_names;
  plan::ProfilePeaks peaks;
  double compute_time_s = 0.0;
};

/// Plans `path` on `machine` (its profile and max_jerk decide the ramps) and simulates it.
/// Throws amctl::Error on bad input (file:line:col), a sample rate at or below the models'
/// Nyquist limit, an empty measuring range, or a file without moves.
[[nodiscard]] PrintSimulationResult simulate_print(const plan::GcodeInput& input,
                                                   const machine::Machine& machine,
                                                   const AxisModel& model_x,
                                                   const AxisModel& model_y,
                                                   const PrintSimulationOptions& options);

/// `amctl simulate --json`. with_peaks adds peak_accel_mm_s2 / peak_jerk_mm_s3.
[[nodiscard]] Json to_json(const PrintSimulationResult& result, bool with_peaks);
/// The quality report alone (also used by the seed-000 sweep).
[[nodiscard]] Json to_json(const QualityReport& report, const std::vector<std::string>& feature_names);

}  // namespace amctl::dynamics
