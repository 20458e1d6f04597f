#include "amctl/plan/stream.hpp"

#include "amctl/machine/kinematics.hpp"

#include <cerrno>
#include <utility>

#include <sys/stat.h>

#include "amctl/bedmesh/transform.hpp"
#include "amctl/core/error.hpp"
#include "amctl/formats/input.hpp"
#include "amctl/gcode/line_reader.hpp"

namespace amctl::plan {
namespace {

/// The planner's output written into the batch being filled.
class BatchWriter final : public PlanSink {
 public:
  PlanBatch* batch = nullptr;

  void on_planned(const PlannedMove& m) override { batch->moves.push_back(m); }
  void on_dwell(double start_time_s, double duration_s, std::uint64_t line) override {
    event(PlanEvent::Kind::dwell, start_time_s, line).duration_s = duration_s;
  }
  void on_heater(double time_s, const gcode::HeaterCommand& cmd) override {
    event(PlanEvent::Kind::heater, time_s, cmd.line).heater = cmd;
  }
  void on_progress(double time_s, const gcode::ProgressMarker& m) override {
    event(PlanEvent::Kind::progress, time_s, m.line).progress = m;
  }
  void on_untimed(double time_s, std::string_view name, std::uint64_t line) override {
    event(PlanEvent::Kind::untimed, time_s, line).name = std::string(name);
  }
  void on_layer_change(double time_s, std::int32_t layer, std::uint64_t line) override {
    event(PlanEvent::Kind::layer, time_s, line).layer = layer;
  }
  void on_fan(double time_s, double fraction, std::uint64_t line) override {
    event(PlanEvent::Kind::fan, time_s, line).fan_fraction = fraction;
  }
  void on_range_error(const RangeError& e) override {
    event(PlanEvent::Kind::range_error, e.at_s, e.line).range = e;
  }
  void on_input_shaping(double time_s, const gcode::InputShapingCommand& cmd) override {
    event(PlanEvent::Kind::input_shaping, time_s, cmd.line).shaping = cmd;
  }

 private:
  PlanEvent& event(PlanEvent::Kind kind, double time_s, std::uint64_t line) {
    PlanEvent& e = batch->events.emplace_back();
    e.kind = kind;
    e.before_move = batch->moves.size();
    e.time_s = time_s;
    e.line = line;
    return e;
  }
};

std::optional<bedmesh::Settings> bedmesh_settings(const machine::Machine& m) {
  if (m.klipper_config.empty()) return std::nullopt;
  return bedmesh::read_klipper(m.klipper_config, SourceLocation{m.name, 0, 0});
}

gcode::InterpreterOptions source_interpreter_options(const machine::Machine& m, bool strict) {
  gcode::InterpreterOptions o = interpreter_options(m);
  o.strict = strict;
  return o;
}

}  // namespace

macro::ToolheadInfo toolhead_info(const machine::Machine& m) {
  macro::ToolheadInfo t;
  t.max_velocity_mm_s = m.max_velocity_mm_s;
  t.max_accel_mm_s2 = m.max_accel_mm_s2;
  t.square_corner_velocity_mm_s = m.square_corner_velocity_mm_s;
  t.minimum_cruise_ratio = m.minimum_cruise_ratio;
  // Klipper's axis_minimum/maximum: the ranges the kinematics checks moves against.
  const kinematics::MoveRules rules = machine::make_kinematics(m)->move_rules();
  std::array<double, 3> lo{}, hi{};
  for (std::size_t a = 0; a < 3; ++a) {
    if (!rules.range_min_mm[a] || !rules.range_max_mm[a]) return t;  // every axis's range needed
    lo[a] = *rules.range_min_mm[a];
    hi[a] = *rules.range_max_mm[a];
  }
  t.axis_minimum_mm = lo;
  t.axis_maximum_mm = hi;
  return t;
}

struct PlanSource::Impl {
  Impl(std::unique_ptr<gcode::LineReader> r, const machine::Machine& m, const SourceOptions& o)
      : machine(m),
        options(o),
        reader(std::move(r)),
        interp(source_interpreter_options(m, o.strict), reader->name()),
        planner(machine, writer, o.planner) {
    summary.file = reader->name();
    summary.machine_name = machine.name;
    interp.set_exclusion_bypassed(o.bypass_exclusion);
    if (!machine.klipper_config.empty()) {
      macros.emplace(machine.klipper_config, toolhead_info(machine));
      if (macros->empty()) {
        macros.reset();  // no [gcode_macro]: the interpreter's path stays as it is
      } else {
        interp.set_expander(&*macros);
      }
    }
    // Klipper's [bed_mesh]: its move transform sits between the interpreter and the planner
    // (docs/bedmesh.md); without the section the interpreter feeds the planner directly.
    if (auto bm = bedmesh_settings(machine)) {
      mesh.emplace(std::move(*bm), planner);
      sink = &*mesh;
    }
  }

  void fill(PlanBatch& batch);
  void close();

  machine::Machine machine;
  SourceOptions options;
  std::unique_ptr<gcode::LineReader> reader;
  gcode::Interpreter interp;
  std::optional<macro::MacroExpander> macros;
  BatchWriter writer;
  Planner planner;
  std::optional<bedmesh::MeshTransform> mesh;
  gcode::EventSink* sink = &planner;  ///< what the interpreter feeds
  StreamSummary summary;
  bool done = false;
};

void PlanSource::Impl::fill(PlanBatch& batch) {
  writer.batch = &batch;
  const std::size_t target = options.batch_moves == 0 ? 1 : options.batch_moves;
  std::string_view line;
  bool more = true;
  while (batch.moves.size() < target && (more = reader->next(line))) {
    interp.feed(line, reader->line_number(), *sink);
  }
  if (!more) {
    planner.finish();
    close();
  }
  batch.feature_names = &interp.annotations().feature_names;
}

void PlanSource::Impl::close() {
  done = true;
  summary.end_time_s = planner.print_time_s();
  summary.lines = reader->line_number();
  summary.bytes = reader->bytes_read();
  summary.ended_without_newline = reader->ended_without_newline();
  summary.skipped_lines = interp.skipped_lines();
  summary.feature_names = interp.annotations().feature_names;
  summary.unknown_commands = interp.unknown_commands();
  summary.ignored_commands = interp.ignored_commands();
  if (macros) summary.macros = macros->reports();
  summary.excluded_objects = interp.excluded_objects();
  summary.excluded_moves = interp.excluded_moves();
  summary.slicer_estimate_s = interp.annotations().slicer_estimate_s;
  summary.slicer_name = interp.annotations().slicer_name;
  summary.diagnostics = planner.diagnostics();
  summary.final_limits = planner.limits();
  if (mesh) {
    summary.bed_mesh = BedMeshSummary{mesh->stats().moves_in, mesh->stats().pieces_out,
                                      mesh->stats().profile_loads};
  }
}

namespace {

std::unique_ptr<gcode::LineReader> open_reader(const GcodeInput& input) {
  InputFile* f = input.file();
  if (f == nullptr) return formats::open_gcode_reader(input.path());
  if (f->position() != 0) f->rewind();
  return formats::open_gcode_reader(*f);
}

}  // namespace

RewindableGcode::RewindableGcode(const GcodeInput& input) : path_(input.path()), file_(input.file()) {
  struct stat st {};
  if (file_ == nullptr && path_ != "-" && ::stat(path_.c_str(), &st) != 0 && errno == ENOTDIR) {
    return;  // a member of an archive (or an error the reader names when it opens the path)
  }
  if (file_ == nullptr) {
    owned_ = std::make_unique<InputFile>(input.path(), gcode::gcode_input_options(true));
    file_ = owned_.get();
  }
}

PlanSource::PlanSource(const GcodeInput& input, const machine::Machine& machine, SourceOptions options)
    : impl_(std::make_unique<Impl>(open_reader(input), machine, options)) {}

PlanSource::PlanSource(std::string_view text, std::string name, const machine::Machine& machine,
                       SourceOptions options)
    : impl_(std::make_unique<Impl>(std::make_unique<gcode::LineReader>(text, std::move(name)),
                                   machine, options)) {}

PlanSource::~PlanSource() = default;

bool PlanSource::next(PlanBatch& batch) {
  batch.clear();
  if (impl_->done) return false;
  try {
    impl_->fill(batch);
  } catch (const Error& e) {
    // Errors raised below the interpreter (planner, limits) know the line but not the file;
    // a line decoded from a container (binary G-code, a 3MF plate) also says where it was.
    const bool no_file = e.where().file.empty() && e.where().line != 0;
    const bool this_file = e.where().file == impl_->reader->name() && e.where().line != 0;
    if (no_file || this_file) {
      const std::string origin = e.where().line == impl_->reader->line_number()
                                     ? impl_->reader->origin_of_line()
                                     : std::string();
      if (no_file || !origin.empty()) {
        throw Error(SourceLocation{impl_->reader->name(), e.where().line, e.where().column},
                    origin.empty() ? e.detail() : e.detail() + " (in " + origin + ")");
      }
    }
    throw;
  }
  return !batch.empty() || !impl_->done;
}

bool PlanSource::done() const { return impl_->done; }
const StreamSummary& PlanSource::summary() const { return impl_->summary; }
const machine::Machine& PlanSource::machine() const { return impl_->machine; }

const StreamSummary& run_pipeline(PlanSource& source, std::span<Stage* const> stages,
                                  std::span<Sink* const> sinks) {
  PlanBatch batch;
  auto deliver = [&](PlanBatch& b, std::size_t first_stage) {
    for (std::size_t i = first_stage; i < stages.size(); ++i) stages[i]->process(b);
    if (b.empty()) return;
    for (Sink* s : sinks) s->consume(b);
  };
  while (source.next(batch)) deliver(batch, 0);
  // Each stage's held-back tail goes through the stages after it.
  for (std::size_t i = 0; i < stages.size(); ++i) {
    batch.clear();
    stages[i]->finish(batch);
    deliver(batch, i + 1);
  }
  for (Sink* s : sinks) s->finish(source.summary());
  return source.summary();
}

}  // namespace amctl::plan
