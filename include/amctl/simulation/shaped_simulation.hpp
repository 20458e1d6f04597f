#pragma once
// The belt dynamics driven by an input-shaped command, exactly (docs/dynamics.md, "Input
// shaping").
//
// The shaped command of an axis is x_s(t) = sum_i a_i x(t - d_i) (Klipper's input shaper:
// weights summing to 1, delays centred), a piecewise polynomial again: the plan's breaks
// shifted by every delay. shaping::ShapedPieceStream builds those pieces exactly, the same
// stream `amctl steps` feeds the motors; the motors' commands are the linear motor map of the
// shaped toolhead (X, Y, and Z where the map has it), and one dynamics::PieceSimulator (the
// plant engine, plant.hpp) propagates the modes exactly across every piece. So the shaped
// simulation is exact at the sample times, with one plant state whatever the number of
// impulses, and in motor space with a different shaper per axis too.
//
// The quality meter sees the PLANNED path (the G-code path) as the command and the shaped
// nozzle as the simulated position, so the shaper's smoothing counts as contour error. The
// distance to the planned path measures the shaped command itself against the plan (the smoothing).
#include <array>
#include <cstddef>
#include <deque>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/dynamics/metrics.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/dynamics/print_simulation.hpp"
#include "amctl/dynamics/simulate.hpp"
#include "amctl/gcode/events.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/stream.hpp"
#include "amctl/dynamics/plant.hpp"
#include "amctl/shaping/shaped_pieces.hpp"
#include "amctl/shaping/shaper.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::simulation {

/// The shaped command's own deviation from the plan.
struct SmoothingFigures {
  double max_mm = 0.0;             ///< largest distance of the shaped command from the plan
  double rms_mm = 0.0;
  /// Largest distance within [T_c + min_delay, T_c + max_delay] of a corner junction T_c
  /// (turn above MetricsOptions::corner_angle_deg).
  double max_at_corners_mm = 0.0;
  std::uint64_t samples = 0;
};

/// Simulation and metrics of a move stream with a shaped command, in bounded memory: like
/// dynamics::StreamingSimulation, moves are pushed one by one; the shaped pieces go to the
/// plant engine as they are completed, and a window of moves is kept for the metrics (the
/// planned path around the simulated time plus the contour search's neighbours). Residual vibration of a move is the free vibration of the shaped nozzle at the
/// first sample at or after (move end + max delay), when the shaped command has left the
/// move (with a single tap at delay 0: at the first sample at or after the move end).
class ShapedStreamingSimulation {
 public:
  using RowSink = dynamics::StreamingSimulation::RowSink;
  /// shaper_x, shaper_y: the shaper of each cartesian axis (nullopt: the axis follows the
  /// plan). The simulated axes are X and Y, or with sim_options.motor_space the two motors.
  ShapedStreamingSimulation(const dynamics::AxisModel& model_0, const dynamics::AxisModel& model_1,
                            const dynamics::SimulationOptions& sim_options,
                            dynamics::MetricsOptions metrics_options,
                            const std::optional<shaping::Shaper>& shaper_x,
                            const std::optional<shaping::Shaper>& shaper_y,
                            RowSink rows = nullptr, std::size_t window_moves = 256);
  ~ShapedStreamingSimulation();
  ShapedStreamingSimulation(const ShapedStreamingSimulation&) = delete;
  ShapedStreamingSimulation& operator=(const ShapedStreamingSimulation&) = delete;

  void push(const plan::PlannedMove& move);
  /// Simulates the rest (through the settle time) and returns the nozzle's report.
  [[nodiscard]] dynamics::QualityReport finish();
  /// After finish(): the shaped command against the plan.
  [[nodiscard]] const SmoothingFigures& smoothing() const { return smoothing_; }
  /// samples; axis_state_updates: the plant engine's mode-block updates; split_steps: the
  /// shaped pieces simulated.
  [[nodiscard]] dynamics::SimulationStats stats() const;
  [[nodiscard]] std::size_t max_window_moves() const { return max_buffer_; }
  /// Plant engines run: 1 (the shaped command is one piece stream).
  [[nodiscard]] std::size_t simulators() const { return 1; }
  /// The first combined sample is this many steps from the first move's start (<= 0): the
  /// shaped command starts moving min_delay early.
  [[nodiscard]] long long grid_start_steps() const { return k_start_; }

 private:
  struct Pending {
    double t_s = 0.0;
    std::array<double, 2> sim_mm{};  // shaped nozzle (stream coordinates)
    std::array<double, 2> cmd_mm{};  // shaped command (stream coordinates)
    std::array<double, 2> vib_mm{};  // free vibration of the shaped nozzle per simulated axis
  };
  void feed(bool final);
  void on_sample(const dynamics::PlantSample& s);
  void emit(bool flush);

  dynamics::MetricsOptions metrics_opt_;
  dynamics::SimulationOptions sim_opt_;
  const dynamics::AxisModel model_0_, model_1_;
  shaping::ShapedPieceStream shaped_;
  std::optional<dynamics::PieceSimulator> engine_;
  std::vector<shaping::AxisPiece> pieces_;  // completed, not yet simulated
  const shaping::AxisPiece* piece_ = nullptr;  // the piece being simulated (nullptr: at rest)
  shaping::AxisPiece last_piece_;
  bool have_last_piece_ = false;
  std::array<std::array<double, 3>, 2> rows_map_{};  // motor rows (identity: X, Y)
  double det_ = 1.0;
  dynamics::QualityMeter meter_;
  RowSink rows_;
  std::size_t window_;
  double h_ = 0.0;
  double settle_s_ = 0.0;
  double max_delay_s_ = 0.0, min_delay_s_ = 0.0;
  long long k_start_ = 0;       // sample k is at t0 + (k_start_ + k) h
  std::size_t lookahead_ = 0;   // samples from a sample to the one its residual is read at
  std::vector<plan::PlannedMove> buf_;
  std::vector<std::array<double, 2>> offsets_;  // per buf_ move: the stream's XY offset (G92)
  std::size_t base_ = 0;
  std::size_t max_buffer_ = 0;
  bool started_ = false;
  double t0_ = 0.0;             // first move's start
  double motion_end_s_ = 0.0;
  std::deque<Pending> pending_;
  std::size_t front_k_ = 0;     // index of pending_.front()
  std::size_t emitted_ = 0;
  std::size_t next_end_ = 0;    // first move whose residual has not been reported
  double last_t_ = 0.0;
  // corner junctions (plan times) for SmoothingFigures::max_at_corners_mm
  std::deque<double> corner_times_;
  bool have_dir_ = false;
  double last_dir_[2] = {0.0, 0.0};
  double sum_sq_smoothing_ = 0.0;
  SmoothingFigures smoothing_;
};

/// The shaped simulation as a sink of the plan stream (what `amctl simulate` and `amctl
/// report` run): every planned move is pushed to `sim`; an M593 after the first move is a
/// warning (a change of shaping mid-print is not modelled). finish() throws for a stream
/// without moves when require_moves, else leaves the report empty (moves() == 0).
class ShapedSimulationSink final : public plan::Sink {
 public:
  ShapedSimulationSink(ShapedStreamingSimulation& sim, std::vector<std::string>& warnings,
                       bool require_moves = true);
  void consume(const plan::PlanBatch& batch) override;
  void finish(const plan::StreamSummary& summary) override;
  [[nodiscard]] const dynamics::QualityReport& report() const { return report_; }
  [[nodiscard]] std::size_t moves() const { return moves_; }
  [[nodiscard]] const std::vector<std::string>& feature_names() const { return feature_names_; }

 private:
  ShapedStreamingSimulation& sim_;
  std::vector<std::string>& warnings_;
  bool require_moves_ = true;
  dynamics::QualityReport report_;
  std::size_t moves_ = 0;
  std::set<std::uint16_t> used_features_;
  std::vector<std::string> feature_names_;
};

// ------------------------------------------------------------------------------ whole print

/// One axis' shaper as configured: type (shaping::parse_shaper_spec), frequency, damping
/// ratio, and where it came from ("--shaper", "printer.cfg", "machine", "M593").
struct AxisShaperSetting {
  std::string type = "mzv";
  double freq_hz = 0.0;
  double damping_ratio = 0.1;
  std::string source;
  /// Whose definition of the type (shaping::Firmware): Marlin's on a Marlin machine and for
  /// M593, Klipper's elsewhere.
  shaping::Firmware firmware = shaping::Firmware::klipper;
  /// Marlin: impulse times on this grid [Hz] (FT_MOTION's FTM_FS), 0: exact (the stepper
  /// INPUT_SHAPING ZV that M593 sets runs on the step timer).
  double marlin_sample_rate_hz = 0.0;
};

/// The definition a machine's own shaper setting runs with. On a Marlin machine, ZV is
/// Marlin's stepper INPUT_SHAPING ZV (what M593 and INPUT_SHAPING_X/Y set; on the step timer,
/// exact times; equal to Klipper's ZV). Other types keep Klipper's definitions: the bundled
/// Marlin-derived machines that name one (Prusa MK4, MINI: MZV) run Prusa-Firmware-Buddy's
/// input shaper, a port of Klipper's (its MZV decays by K^(3/4)); FT_MOTION's definitions
/// are asked for with ShaperRequest::firmware.
void apply_machine_firmware(const machine::Machine& machine, AxisShaperSetting& setting);
/// The definition asked for: Marlin's means FT_MOTION's (times on its 1 kHz grid).
void apply_requested_firmware(shaping::Firmware firmware, AxisShaperSetting& setting);

/// The names of an axis' shaper parameters in messages (the flags or config keys).
struct ShaperParamNames {
  std::string type = "--shaper";
  std::string freq = "--shaper-freq-hz";
  std::string damping = "--shaper-damping-ratio";
};

struct ShaperSettings {
  std::optional<AxisShaperSetting> x, y;
  ShaperParamNames names_x, names_y;  ///< for messages
  std::vector<std::string> warnings;  ///< found while resolving them (M593)
  [[nodiscard]] bool any() const { return x.has_value() || y.has_value(); }
};

/// Builds the shaper of one axis. Throws amctl::Error naming the parameter for an unknown
/// type, a frequency <= 0 or at/above the Nyquist limit of the sample rate (the simulation
/// samples the shaped command at sample_rate_hz), a damping ratio outside [0, 1).
[[nodiscard]] shaping::Shaper make_axis_shaper(const AxisShaperSetting& s, double sample_rate_hz,
                                               const ShaperParamNames& names = {});

/// The M593 commands of the input (planned on `machine`) that come before its first move: a
/// pre-pass over the first batch of the plan stream. Give the rewindable InputFile the
/// simulation then reads (standard input and FIFOs are read once); given only a path that is
/// not a regular file ("-", a FIFO), there is no second pass to make: empty.
[[nodiscard]] std::vector<gcode::InputShapingCommand> m593_before_first_move(const plan::GcodeInput& input,
                                                                            const machine::Machine& machine);

/// Marlin's input shaping after `commands` (M593, in order), from Marlin's M593.cpp: the
/// stepper shaping is ZV (Marlin's definition, exact times); D sets the damping ratio (accepted in [0, 1], Marlin's default
/// SHAPING_ZETA 0.15), F the frequency (0 = off; negative: rejected), X / Y select the axes
/// (neither: both); T is documented as not implemented and ignored. A rejected value, an
/// axis given a damping ratio but never a frequency (the firmware's compiled-in default is not
/// in the file) and a T word are reported in `warnings`. Source "M593 line N".
[[nodiscard]] ShaperSettings shapers_from_m593(std::span<const gcode::InputShapingCommand> commands);

/// What a user asked for (the `simulate` flags, or the Python keywords): a shaper for X and
/// Y or per axis, or none at all.
struct ShaperRequest {
  std::optional<std::string> type, type_x, type_y;
  std::optional<double> freq_hz, freq_x_hz, freq_y_hz;
  double damping_ratio = 0.1;  ///< Klipper's default
  bool none = false;           ///< no shaper, whatever the machine or the file says
  /// Whose definitions every shaper in use takes (the flags', the machine's or M593's);
  /// unset: apply_machine_firmware, and Marlin's stepper ZV for M593.
  std::optional<shaping::Firmware> firmware;
  /// How the caller spells these parameters, for messages.
  std::string type_name = "--shaper", type_x_name = "--shaper-x", type_y_name = "--shaper-y";
  std::string freq_name = "--shaper-freq-hz", freq_x_name = "--shaper-freq-x-hz",
              freq_y_name = "--shaper-freq-y-hz", damping_name = "--shaper-damping-ratio",
              none_name = "--no-shaper", firmware_name = "--shaper-firmware";
  [[nodiscard]] bool any() const {
    return type || type_x || type_y || freq_hz || freq_x_hz || freq_y_hz;
  }
};

/// The shapers a simulation of `path` on `machine` runs with, by precedence: the request,
/// then the machine's [input_shaper] (a frequency of 0 leaves an axis unshaped), then
/// Marlin's M593 before the first move of the file (a later M593 is a warning). A type without
/// a frequency is an error naming the parameter; `none` with a shaper asked is an error.
/// Resolution warnings (an M593 overridden, ignored words) are in `warnings`.
[[nodiscard]] ShaperSettings resolve_shapers(const ShaperRequest& request,
                                             const machine::Machine& machine,
                                             const plan::GcodeInput& input);

struct ShapedPrintResult {
  dynamics::PrintSimulationResult shaped;   ///< the shaped nozzle against the planned path
  dynamics::PrintSimulationResult without;  ///< the same plan without a shaper
  ShaperSettings settings;
  std::optional<shaping::Shaper> shaper_x, shaper_y;
  SmoothingFigures smoothing;               ///< the shaped command against the plan
  std::size_t simulators = 0;               ///< distinct delays (or (axis, delay) pairs)
  std::vector<std::string> warnings;
};

/// Plans `path` on `machine` and simulates it once with and once without the shapers (one
/// pass over the plan). The CSV of `options` gets the shaped run. An M593 after the first
/// move is reported in `warnings` (a change of shaping mid-print is not modelled). Throws amctl::Error as
/// dynamics::simulate_print, and for bad shaper settings (make_axis_shaper, command_taps).
[[nodiscard]] ShapedPrintResult simulate_shaped_print(const plan::GcodeInput& input,
                                                      const machine::Machine& machine,
                                                      const dynamics::AxisModel& model_x,
                                                      const dynamics::AxisModel& model_y,
                                                      const dynamics::PrintSimulationOptions& options,
                                                      const ShaperSettings& shapers);

/// `amctl simulate --json` with a shaper: dynamics::to_json of the shaped run plus `shaper`
/// (per axis: type, freq_hz, damping_ratio, source, duration_s, klipper_smoothing_mm at the
/// machine's accel and scv), `smoothing_mm` (max, rms, max_at_corners) and `without_shaper`
/// (the same quality keys for the unshaped run).
[[nodiscard]] Json to_json(const ShapedPrintResult& result, bool with_peaks);

}  // namespace amctl::simulation
