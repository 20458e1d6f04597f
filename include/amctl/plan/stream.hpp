#pragma once
// The plan stream: one pipeline for every job (docs/architecture.md, "The plan stream").
//
//   PlanSource ──batches──> Stage ──> Stage ──> ... ──> Sink, Sink, ...
//
// A PlanSource reads a G-code file (or text) for a machine and yields batches of planned
// moves, each carrying its file line, layer and feature, with the non-motion events
// (dwells, heaters, layer changes, ...) interleaved at their place. Pull-based: a caller
// (the CLI, a test, the Python binding) asks for the next batch, so it never makes a call
// per move and can run without holding any lock between batches. Stages transform the stream
// (a re-timing, input shaping, compensation); sinks consume it (the estimate report, the
// simulator, step generation, CSV). Memory is bounded: filling a batch stops at the first
// line after which it holds SourceOptions::batch_moves moves, and one line can release at most
// the planner's look-ahead queue (PlannerOptions::max_queue), so a batch holds about
// batch_moves moves and never more than batch_moves + max_queue, plus the events between them.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/gcode/events.hpp"
#include "amctl/core/input.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/macro/expander.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/planner.hpp"

namespace amctl::plan {

/// A non-motion event of the plan, at its print time.
struct PlanEvent {
  enum class Kind : std::uint8_t { dwell, heater, progress, untimed, layer, fan, input_shaping, range_error };
  Kind kind = Kind::dwell;
  /// Number of the batch's moves that come before this event (events sit between moves).
  std::size_t before_move = 0;
  double time_s = 0.0;          ///< print time at which it takes effect
  double duration_s = 0.0;      ///< dwell
  double fan_fraction = 0.0;    ///< fan, 0..1
  std::int32_t layer = 0;       ///< layer change: the new layer
  std::uint64_t line = 0;
  gcode::HeaterCommand heater{};
  gcode::ProgressMarker progress{};
  std::string name;             ///< untimed command (G28, probing, ...)
  gcode::InputShapingCommand shaping{};  ///< input_shaping (M593)
  RangeError range{};           ///< range_error (Klipper "Move out of range"), at_s == time_s
};

/// One piece of the stream: moves in time order and the events between them.
struct PlanBatch {
  std::vector<PlannedMove> moves;
  std::vector<PlanEvent> events;  ///< sorted by before_move, then arrival
  /// The run's feature names so far, indexed by PlannedMove::feature (every move of the
  /// batch has its name there). Owned by the source: valid while the batch is consumed.
  const std::vector<std::string>* feature_names = nullptr;

  void clear() { moves.clear(); events.clear(); }
  [[nodiscard]] bool empty() const { return moves.empty() && events.empty(); }
};

/// Calls on_move(const PlannedMove&) and on_event(const PlanEvent&) in stream order.
template <class OnMove, class OnEvent>
void for_each_in_order(const PlanBatch& b, OnMove&& on_move, OnEvent&& on_event) {
  std::size_t m = 0;
  for (const PlanEvent& e : b.events) {
    for (; m < e.before_move; ++m) on_move(b.moves[m]);
    on_event(e);
  }
  for (; m < b.moves.size(); ++m) on_move(b.moves[m]);
}

/// What Klipper's [bed_mesh] did to the moves (docs/bedmesh.md): moves made while a profile
/// was loaded, the moves the planner received for them, profiles loaded.
struct BedMeshSummary {
  std::uint64_t meshed_moves = 0;
  std::uint64_t pieces = 0;
  std::uint64_t profile_loads = 0;
};

/// What the source knows once the input is exhausted: the reader's and interpreter's
/// counts and the planner's diagnostics. Sinks receive it in finish().
struct StreamSummary {
  std::string file;                 ///< name used in messages ("-" = standard input)
  std::string machine_name;
  double end_time_s = 0.0;          ///< print time at the end of the last move or dwell
  std::uint64_t lines = 0;
  std::uint64_t bytes = 0;
  bool ended_without_newline = false;
  std::uint64_t skipped_lines = 0;  ///< malformed lines skipped in lenient mode
  std::vector<std::string> feature_names;  ///< by PlannedMove::feature
  std::vector<gcode::UnknownCommand> unknown_commands;
  std::map<std::string, std::uint64_t> ignored_commands;
  /// Klipper macros called, expanded or skipped (printer.cfg [gcode_macro]; docs/macros.md).
  std::vector<macro::MacroReport> macros;
  /// Klipper [exclude_object]: objects excluded at some point, and the moves not made.
  std::vector<gcode::ExcludedObject> excluded_objects;
  std::uint64_t excluded_moves = 0;
  std::optional<double> slicer_estimate_s;
  std::string slicer_name;
  PlannerDiagnostics diagnostics;
  Planner::Limits final_limits{};
  /// Set on a printer.cfg with [bed_mesh].
  std::optional<BedMeshSummary> bed_mesh;
};

/// Receives the stream.
class Sink {
 public:
  virtual ~Sink() = default;
  virtual void consume(const PlanBatch& batch) = 0;
  /// End of the stream (called once, after the last batch).
  virtual void finish(const StreamSummary& summary) { (void)summary; }
};

/// Transforms the stream in place. A stage may hold moves back (a window for a filter that
/// looks ahead) and release them in later batches or in finish().
class Stage {
 public:
  virtual ~Stage() = default;
  virtual void process(PlanBatch& batch) = 0;
  /// End of the stream: append whatever is still held back to `tail`.
  virtual void finish(PlanBatch& tail) { (void)tail; }
};

struct SourceOptions {
  PlannerOptions planner;
  /// Treat malformed lines as errors (true) or skip and count them.
  bool strict = true;
  /// Moves per batch: filling stops once the batch holds this many (one G-code line may add a
  /// whole look-ahead flush beyond it; the last batch may hold fewer). Events do not count.
  std::size_t batch_moves = 4096;
  /// Klipper [exclude_object]: make the moves of excluded objects anyway (EXCLUDE_OBJECT is
  /// still read and reported). The estimate plans a file both ways for the time exclusion saves.
  bool bypass_exclusion = false;
};

/// Interpreter options implied by a machine (arcs, firmware retraction).
gcode::InterpreterOptions interpreter_options(const machine::Machine& m);

/// What a macro sees of the machine as printer.toolhead (limits and axis ranges).
macro::ToolheadInfo toolhead_info(const machine::Machine& m);

/// The G-code a job reads: a path ("-" = standard input), opened by each PlanSource over it,
/// or an input already open (amctl::InputFile), which a job that plans the file more than once
/// opens rewindable: each PlanSource over it starts again at its first byte, so standard input
/// and a FIFO are read once (core/input.hpp). Converts from a path.
class GcodeInput {
 public:
  GcodeInput(const std::string& path) : path_(path) {}  // NOLINT: a path is an input
  GcodeInput(const char* path) : path_(path) {}         // NOLINT
  GcodeInput(InputFile& file) : path_(file.path()), file_(&file) {}  // NOLINT
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] InputFile* file() const { return file_; }

 private:
  std::string path_;
  InputFile* file_ = nullptr;
};

/// An input open for several passes: `input`'s InputFile when it has one, else `input`'s path
/// opened rewindable here; a plate named inside a 3MF archive ("a.gcode.3mf/Metadata/
/// plate_2.gcode") stays a path, which each pass opens again (the archive is a regular file).
class RewindableGcode {
 public:
  explicit RewindableGcode(const GcodeInput& input);
  RewindableGcode(const RewindableGcode&) = delete;
  RewindableGcode& operator=(const RewindableGcode&) = delete;
  operator GcodeInput() { return file_ != nullptr ? GcodeInput(*file_) : GcodeInput(path_); }  // NOLINT

 private:
  std::string path_;
  std::unique_ptr<InputFile> owned_;
  InputFile* file_ = nullptr;
};

/// G-code + machine -> planned moves, batch by batch. Every amctl::Error raised while
/// reading, interpreting or planning carries the source's file name.
class PlanSource {
 public:
  /// Reads the file at `input.path()` ("-" = standard input), or the open input from its first
  /// byte (rewinding it when a pass before read some of it).
  PlanSource(const GcodeInput& input, const machine::Machine& machine, SourceOptions options = {});
  /// Reads `text` from memory; `name` appears in messages.
  PlanSource(std::string_view text, std::string name, const machine::Machine& machine,
             SourceOptions options = {});
  ~PlanSource();
  PlanSource(const PlanSource&) = delete;
  PlanSource& operator=(const PlanSource&) = delete;

  /// Fills `batch` (cleared first) with the next moves and events. Returns false, with an
  /// empty batch, once the stream has ended; summary() is complete from then on.
  bool next(PlanBatch& batch);

  [[nodiscard]] bool done() const;
  [[nodiscard]] const StreamSummary& summary() const;
  [[nodiscard]] const machine::Machine& machine() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Pulls every batch from `source` through `stages` (in order) into every sink, then calls
/// finish on stages and sinks. Returns the source's summary.
const StreamSummary& run_pipeline(PlanSource& source, std::span<Stage* const> stages,
                                  std::span<Sink* const> sinks);

/// Convenience for the common case without stages.
inline const StreamSummary& run_pipeline(PlanSource& source, std::span<Sink* const> sinks) {
  return run_pipeline(source, {}, sinks);
}

/// Calls a function for every move (tests, fuzzing, quick taps; a class of its own is
/// clearer for anything with state).
class CallbackSink final : public Sink {
 public:
  explicit CallbackSink(std::function<void(const PlannedMove&)> on_move)
      : on_move_(std::move(on_move)) {}
  void consume(const PlanBatch& batch) override {
    for (const PlannedMove& m : batch.moves) on_move_(m);
  }

 private:
  std::function<void(const PlannedMove&)> on_move_;
};

/// Collects every move of the stream in memory (tests, short examples; not for whole prints).
class CollectSink final : public Sink {
 public:
  void consume(const PlanBatch& batch) override {
    for (PlanEvent e : batch.events) {
      e.before_move += moves.size();
      events.push_back(std::move(e));
    }
    moves.insert(moves.end(), batch.moves.begin(), batch.moves.end());
  }
  void finish(const StreamSummary& s) override { summary = s; }
  std::vector<PlannedMove> moves;
  std::vector<PlanEvent> events;  ///< before_move counts from the first move of the stream
  StreamSummary summary;
};

}  // namespace amctl::plan
