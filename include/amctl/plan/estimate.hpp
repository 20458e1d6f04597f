#pragma once
// The main job: G-code file -> PlanSource -> EstimateSink -> print-time report.
// Streams the file through a bounded buffer; memory grows only with the number of layers,
// features and distinct unknown commands, never with the number of moves.
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "amctl/gcode/interpreter.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planner.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::plan {

struct EstimateOptions {
  PlannerOptions planner;
  /// Record (line, time) checkpoints every this many seconds of print time (for M73).
  double checkpoint_interval_s = 0.0;
  /// Treat malformed lines as errors (true) or skip and count them.
  bool strict = true;
  /// Called for every planned move (a CallbackSink beside the EstimateSink); may be empty.
  std::function<void(const PlannedMove&)> on_move;
  /// The source's options (planner, strictness, batch size) for these estimate options.
  [[nodiscard]] SourceOptions source() const {
    SourceOptions o;
    o.planner = planner;
    o.strict = strict;
    return o;
  }
};

struct FeatureTime {
  std::string name;
  std::uint16_t index = 0;    ///< PlannedMove::feature of the moves counted here
  double time_s = 0.0;        ///< all moves tagged with this feature
  double extrude_time_s = 0.0;
  double path_mm = 0.0;       ///< XYZ length of extruding moves
  double filament_mm = 0.0;   ///< E advanced by extruding moves
  std::uint64_t moves = 0;
};

struct LayerTime {
  std::int32_t layer = 0;
  double start_s = 0.0;
  double time_s = 0.0;
  double z_mm = 0.0;          ///< Z of the first extruding move in the layer
  std::uint64_t first_line = 0;
};

struct TimedEvent {
  double at_s = 0.0;
  std::string what;           ///< e.g. "M109 hotend 215 C (wait)", "G28"
  std::uint64_t line = 0;
};

struct Checkpoint {
  std::uint64_t line = 0;     ///< G-code line of the first move starting at/after time_s
  double time_s = 0.0;
};

struct EstimateReport {
  std::string file;
  std::string machine_name;
  double total_time_s = 0.0;       ///< motion + dwells (heater waits and untimed commands apart)
  double motion_time_s = 0.0;
  double dwell_time_s = 0.0;
  double travel_time_s = 0.0;      ///< moves without extrusion
  double extrude_time_s = 0.0;     ///< moves with positive extrusion
  double extrude_only_time_s = 0.0;  ///< retract / unretract / prime without XYZ motion
  double travel_mm = 0.0;
  double extrude_path_mm = 0.0;
  double filament_mm = 0.0;        ///< net filament fed (extrusion minus retraction)
  double filament_volume_mm3 = 0.0;
  double max_speed_mm_s = 0.0;
  std::uint64_t moves = 0;
  std::uint64_t lines = 0;
  std::uint64_t bytes = 0;
  bool ended_without_newline = false;
  std::uint64_t skipped_lines = 0;        ///< malformed lines skipped in lenient mode
  std::vector<FeatureTime> features;
  std::vector<LayerTime> layers;
  std::vector<TimedEvent> heater_waits;   ///< waits whose duration is not in total_time_s
  std::vector<TimedEvent> heater_sets;
  std::vector<TimedEvent> untimed;        ///< homing, probing, pauses: real time not known
  /// The untimed commands that stop the print for a time no file can know: user pauses
  /// (M0/M1, M125, M226, M600, M601, PAUSE) and bed levelling (G29, G80, G34,
  /// BED_MESH_CALIBRATE, QUAD_GANTRY_LEVEL, Z_TILT_ADJUST, CALIBRATE_Z). Each is also in
  /// `untimed`; `what` names the command and why it pauses. Not in total_time_s.
  std::vector<TimedEvent> pauses;
  /// Klipper machine with position_min/max: the first move out of range. Klipper stops the
  /// print there (at range_error->at_s); the other figures still cover the whole file.
  std::optional<RangeError> range_error;
  std::vector<gcode::UnknownCommand> unknown_commands;
  std::map<std::string, std::uint64_t> ignored_commands;
  /// Klipper macros called: expanded (their moves are in the times) or skipped, and why.
  std::vector<macro::MacroReport> macros;
  /// Klipper [exclude_object]: the objects EXCLUDE_OBJECT excluded (each once, in order of
  /// first exclusion), the moves that were therefore not made, and the print time that saved:
  /// total_time_s of the same file with every move made, less total_time_s (estimate_file /
  /// estimate_text plan the file a second time for it, only when an object was excluded, from
  /// the copy the reader kept for standard input or a FIFO; unset from a bare EstimateSink).
  std::vector<gcode::ExcludedObject> excluded_objects;
  std::uint64_t excluded_moves = 0;
  std::optional<double> exclusion_time_saved_s;
  std::optional<double> slicer_estimate_s;
  std::string slicer_name;
  std::vector<Checkpoint> checkpoints;
  PlannerDiagnostics diagnostics;
  Planner::Limits final_limits{};
};

/// The estimate as a sink of the plan stream: one pass, O(layers + features) memory. Use it
/// beside other sinks to get the report of a run that also simulates, writes CSV, ...
/// The range error as one sentence: line, axis, position, limit, and the time at which Klipper
/// would stop the print. Shown as a warning by the human report; the JSON has `range_error`
/// (the `warnings` list is left as it was, so existing keys keep their values).
[[nodiscard]] std::string describe_range_error(const RangeError& e);

/// Why an untimed command pauses the print ("filament change", "bed levelling", ...), or
/// empty when it is not a pause (homing, probing, calibration). `name` as the interpreter
/// reports it (upper case, e.g. "M600", "BED_MESH_CALIBRATE").
[[nodiscard]] std::string_view pause_reason(std::string_view name);

class EstimateSink final : public Sink {
 public:
  explicit EstimateSink(const machine::Machine& machine, double checkpoint_interval_s = 0.0);
  void consume(const PlanBatch& batch) override;
  void finish(const StreamSummary& summary) override;
  /// The report; complete after finish().
  [[nodiscard]] const EstimateReport& report() const { return r_; }
  [[nodiscard]] EstimateReport take_report() { return std::move(r_); }

 private:
  void add_move(const PlannedMove& m);
  void add_event(const PlanEvent& e);
  void close_layer(double now_s);
  FeatureTime& feature(std::uint16_t idx) {
    if (idx >= r_.features.size()) r_.features.resize(idx + 1u);
    return r_.features[idx];
  }

  EstimateReport r_;
  double checkpoint_interval_s_ = 0.0;
  double next_checkpoint_s_ = 0.0;
  double filament_area_mm2_ = 0.0;
  bool layer_has_z_ = false;
};

/// Estimates a G-code file ("-" = standard input), or an input already open (rewindable;
/// a later write_m73 then reads the same bytes again). Throws amctl::Error on bad input with
/// "file:line:col: ..." in the message.
EstimateReport estimate_file(const GcodeInput& input, const machine::Machine& machine,
                             const EstimateOptions& options = {});

/// One file of a batch (`amctl estimate A B ...`, the fleet's table): its report, or the
/// error that stopped it.
struct EstimateRow {
  std::string file;
  std::optional<EstimateReport> report;
  std::string error;  ///< the amctl::Error's message; empty on success
  double compute_time_s = 0.0;
  /// A report without a single move ("no moves": an empty file, or one of comments only).
  [[nodiscard]] bool no_moves() const { return report && report->moves == 0; }
};

/// Estimates every input on one machine, one after the other; a file that fails is a row
/// with its error and does not stop the others. Inputs are expanded as
/// formats::expand_gcode_inputs does (directories, the plates of a 3MF).
std::vector<EstimateRow> estimate_files(const std::vector<std::string>& inputs,
                                        const machine::Machine& machine,
                                        const EstimateOptions& options = {});

/// Same, on text in memory (tests). `name` appears in messages.
EstimateReport estimate_text(std::string_view gcode, const std::string& name,
                             const machine::Machine& machine, const EstimateOptions& options = {});

}  // namespace amctl::plan

namespace amctl::plan {

/// Writes the input to `output_path` with firmware progress lines "M73 P<percent>
/// R<minutes remaining>" inserted before the moves that start at each checkpoint of
/// `report` (estimate with options.checkpoint_interval_s > 0), and "M73 P100 R0" at the end.
/// Existing M73 lines are dropped; every other line is copied with its own line end. Give the
/// rewindable InputFile the estimate read (standard input and FIFOs are read once). Written
/// through amctl::OutputFile (a regular file whole or not at all; never over the input).
/// Returns the number of M73 lines written.
std::size_t write_m73(const GcodeInput& input, const std::string& output_path,
                      const EstimateReport& report);

}  // namespace amctl::plan
