#pragma once
// Turns G-code text into EventSink events: G0/G1, G2/G3 (I/J and R forms), G4, G10/G11,
// G17-G19, G20/G21, G28, G90/G91, M82/M83, G92, M73, M104/M109/M140/M190/M141/M191,
// M106/M107, M201/M203/M204/M205, M211 (soft endstops on/off), M220/M221, M400, M566, Klipper's SET_VELOCITY_LIMIT,
// SET_KINEMATIC_POSITION, TEMPERATURE_WAIT, M593 (input shaping, passed on as an event), and slicer annotations for layers and features
// (PrusaSlicer/SuperSlicer, Cura, OrcaSlicer/Bambu, ideaMaker).
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "amctl/gcode/command.hpp"
#include "amctl/gcode/events.hpp"
#include "amctl/gcode/expander.hpp"
#include "amctl/gcode/parser.hpp"

namespace amctl::gcode {

struct InterpreterOptions {
  /// Arc linearisation: target chord length [mm], clamps (0 = none), and Marlin's
  /// ARC_SEGMENTS_PER_SEC (0 = off). Segments = max(1, floor(arc length / chord length)),
  /// Klipper's [gcode_arcs] rule; see also min_circle_segments below.
  double mm_per_arc_segment = 1.0;
  double min_arc_segment_mm = 0.0;
  double max_arc_segment_mm = 0.0;
  double arc_segments_per_second = 0.0;
  /// Firmware retraction (G10/G11). Klipper's [firmware_retraction] defaults.
  double retract_length_mm = 0.0;
  double retract_speed_mm_s = 20.0;
  double unretract_extra_length_mm = 0.0;
  double unretract_speed_mm_s = 10.0;
  /// Pause when motors are switched off (M84/M18): Klipper dwells 2 x 0.1 s; Marlin only
  /// waits for the moves to finish (0).
  double motor_off_dwell_s = 0.0;
  /// Treat an unparseable line as an error (default) or count and skip it.
  bool strict = true;
  // The fields below came later (issue 13); they stay last so that positional initialisation
  // of the ones above keeps its meaning.
  /// Marlin MIN_CIRCLE_SEGMENTS (0 = off): an arc sweeping theta gets at least
  /// ceil(n theta / 2 pi) segments (n for a full circle), but no more than keeps each one
  /// >= min_arc_segment_mm (docs/gcode.md, "Arcs").
  int min_circle_segments = 0;
  /// Marlin RETRACT_ZRAISE (M207 Z): G10 raises Z by this much after retracting and G11
  /// lowers it again before recovering (0 = off; like Marlin, hops <= 0.01 mm are ignored).
  double lift_z_mm = 0.0;
  /// Speed of those Z moves; Marlin uses the Z axis's maximum feedrate.
  double lift_z_speed_mm_s = 12.0;
  /// G2/G3 and G17-G19 are commands (false: unknown commands, noted and skipped, as Klipper
  /// without [gcode_arcs] answers "Unknown command").
  bool arcs_enabled = true;
  /// G28 homes X, Y and Z together whatever axes it names, to `home_position_mm` (a delta:
  /// Klipper's delta.py homes all towers at once and the effector ends below the endstops).
  /// Otherwise each named axis (all without names) goes to 0.
  bool home_all_axes = false;
  std::array<double, 3> home_position_mm{0.0, 0.0, 0.0};
  /// Marlin's software endstops [mm, machine coordinates X Y Z] (unset: no limit). As in
  /// Marlin's apply_motion_limits, the target of a move (G0/G1, each arc segment) is clamped
  /// into them on every axis that has been homed (G28), and the clamped point becomes the
  /// current position: a later relative move continues from it. Before an axis is homed it
  /// is not clamped; M211 S0 / S1 switch the clamping off / on. Firmware-retraction moves
  /// are not clamped.
  std::array<std::optional<double>, 3> soft_min_mm{}, soft_max_mm{};
  /// Klipper's EXCLUDE_OBJECT_* commands (klippy/extras/exclude_object.py): `ignored` counts
  /// them as commands with no time effect (TOML machines, presets: as before issue 14);
  /// `unknown` reports them as unknown (a printer.cfg without [exclude_object], where Klipper
  /// answers "Unknown command"); `active` models them: the moves of an excluded object are
  /// not made (docs/gcode.md, "Excluded objects").
  enum class ExcludeObjectMode : std::uint8_t { ignored, unknown, active };
  ExcludeObjectMode exclude_object = ExcludeObjectMode::ignored;
  /// A Klipper dual carriage pair (IDEX, klippy/kinematics/idex_modes.py): two carriages on
  /// `axis`, index 0 the primary rail ([stepper_x] / _y, or a generic_cartesian [carriage]),
  /// 1 the [dual_carriage] rail.
  struct DualCarriage {
    int axis = 0;  ///< 0 = X, 1 = Y
    /// The names SET_DUAL_CARRIAGE CARRIAGE= takes for each carriage (generic_cartesian: the
    /// section names, e.g. carriage_x and carriage_u); empty on cartesian/hybrid printers,
    /// where x / stepper_x and dual_carriage are accepted.
    std::array<std::string, 2> names{};
    std::array<double, 2> position_min_mm{}, position_max_mm{}, position_endstop_mm{};
    std::array<bool, 2> homing_positive_dir{};
    /// Klipper homing_speed of each rail: RESTORE_DUAL_CARRIAGE_STATE moves at the lower one.
    std::array<double, 2> homing_speed_mm_s{5.0, 5.0};
    /// Klipper safe_distance; unset: min(|min0 - min1|, |max0 - max1|) (idex_modes.py).
    std::optional<double> safe_distance_mm;
  };
  /// The pairs, at most one per axis, in Klipper's order (the X pair first); empty: none.
  std::vector<DualCarriage> dual_carriages;
  /// Klipper generic_cartesian's SET_STEPPER_CARRIAGES (generic_cartesian.py): each
  /// stepper's `carriages` expression as configured, by the word after "stepper"; empty: the
  /// command is unknown (any other printer).
  std::map<std::string, std::string, std::less<>> stepper_carriages;
  /// Klipper's checks of SET_STEPPER_CARRIAGES STEPPER=`stepper` CARRIAGES=`expr` given the
  /// expressions in force (`now`): empty when accepted, else the reason. `full` false:
  /// DISABLE_CHECKS=1 (the expression is still read and must name the same carriages in the
  /// same order). Unset: every change is accepted.
  std::function<std::string(const std::map<std::string, std::string, std::less<>>& now,
                            const std::string& stepper, const std::string& expr, bool full)>
      check_stepper_carriages;
  /// Klipper's [bed_mesh] is configured: BED_MESH_PROFILE, BED_MESH_CLEAR and BED_MESH_OFFSET
  /// reach the sink as EventSink::on_bed_mesh (otherwise they are counted as ignored).
  bool bed_mesh = false;
};

/// Layer, feature and slicer figures read from comments.
struct Annotations {
  std::vector<std::string> feature_names{"unknown"};  ///< index 0 = before any ;TYPE:
  std::int32_t layer = -1;
  std::uint16_t feature = 0;
  std::optional<double> slicer_estimate_s;
  std::string slicer_name;  ///< "PrusaSlicer", "Cura", ... when recognised
};

/// An object excluded with EXCLUDE_OBJECT (or M486 through a macro) at some point of the file.
struct ExcludedObject {
  std::string name;             ///< upper case, as Klipper stores it
  std::uint64_t first_line = 0;  ///< line of its first exclusion
};

/// One entry per distinct unknown command name: first place seen and how often. At most
/// kMaxUnknownCommandNames names are kept; the names beyond are counted together under
/// kOtherUnknownCommands (memory stays bounded whatever the file).
inline constexpr std::size_t kMaxUnknownCommandNames = 10000;
inline constexpr std::string_view kOtherUnknownCommands = "(other unknown commands)";
struct UnknownCommand {
  std::string name;
  std::uint64_t first_line = 0;
  std::uint64_t count = 0;
};

class Interpreter {
 public:
  Interpreter(InterpreterOptions options, std::string source_name);

  /// Feeds one line (1-based `line_no`). Throws amctl::Error "file:line:col: ..." on
  /// malformed input when options.strict.
  void feed(std::string_view line, std::uint64_t line_no, EventSink& sink);

  /// Reads a whole file or stream through a bounded buffer, feeding every line.
  void run(class LineReader& reader, EventSink& sink);

  /// Offers every command that is not a plain move to `expander` first (Klipper macros;
  /// nullptr: none). Not owned; it must outlive the interpreter's use.
  void set_expander(CommandExpander* expander);
  /// The state a macro may read (position, modes, homed axes, heater targets).
  [[nodiscard]] InterpreterState state() const;

  [[nodiscard]] const Annotations& annotations() const { return notes_; }
  [[nodiscard]] const std::vector<UnknownCommand>& unknown_commands() const { return unknown_; }
  /// Commands understood but with no effect on motion time (M117, M84, ...), by name.
  [[nodiscard]] const std::map<std::string, std::uint64_t>& ignored_commands() const { return ignored_; }
  [[nodiscard]] std::uint64_t skipped_lines() const { return skipped_lines_; }
  [[nodiscard]] const std::array<double, 4>& machine_position_mm() const { return pos_; }
  /// Objects excluded (in order of first exclusion; a later EXCLUDE_OBJECT RESET=1 does not
  /// remove them here) and the moves not made because they lay in an excluded object.
  [[nodiscard]] const std::vector<ExcludedObject>& excluded_objects() const { return exclude_.ever_excluded; }
  [[nodiscard]] std::uint64_t excluded_moves() const { return exclude_.skipped_moves; }
  /// Counts EXCLUDE_OBJECT commands but makes every move, as if no object were excluded
  /// (for the time saved by exclusion: the same file planned both ways).
  void set_exclusion_bypassed(bool bypass) { exclude_.bypass = bypass; }

 private:
  /// The fast path for plain "G0/G1 X Y Z E F [; comment]" lines: true when it handled the
  /// line, false (with no state changed) when the general path must.
  bool try_plain_move(std::string_view line, std::uint64_t line_no, EventSink& sink);
  /// The built-in handling of the parsed command cmd_ (and its comment).
  void dispatch(std::uint64_t line_no, EventSink& sink);
  /// Parses `line` into cmd_; false (after counting it in lenient mode) if malformed.
  bool parse(std::string_view line, std::uint64_t line_no);
  /// Offers cmd_ to the expander; true when it took the command.
  bool expand(std::string_view line, std::uint64_t line_no, EventSink& sink);
  void handle_word(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void handle_extended(const Command& cmd, std::uint64_t line_no, EventSink& sink);  // extended.cpp
  void handle_comment(std::string_view comment, std::uint64_t line_no, EventSink& sink);
  void do_move(const Params& p, std::uint64_t line_no, EventSink& sink);
  void do_arc(const Command& cmd, const Params& p, bool clockwise, std::uint64_t line_no,
              EventSink& sink);  // arcs.cpp
  /// G10 (`retract`) or G11 (retraction.cpp).
  void firmware_retraction(bool retract, const Params& p, std::uint64_t line_no, EventSink& sink);
  /// M207 or M208 (`code`): firmware retraction settings (retraction.cpp).
  void set_firmware_retraction(int code, const Params& p, std::uint64_t line_no);
  void emit_move(const std::array<double, 4>& target, double speed_mm_s, std::uint64_t line_no,
                 EventSink& sink, bool from_arc, bool from_retract = false, bool clamped = false);
  /// Clamps `target` into the soft endstops on the homed axes; the file's coordinates
  /// `gcode` (when given) follow the clamp, as Marlin's current_position does. True when a
  /// coordinate changed.
  bool soft_clamp(std::array<double, 4>& target, std::array<double, 4>* gcode) const;
  void require_numbers(const Params& p, std::uint64_t line_no) const;
  void apply_feed(const Params& p, std::uint64_t line_no);
  /// Machine-coordinate target of the X/Y/Z/E words under the modal state; the file's own
  /// coordinates after the move go to `new_gcode`.
  [[nodiscard]] std::array<double, 4> target_of(const Params& p, std::array<double, 4>& new_gcode) const;
  /// The same from the X Y Z E values (`value[0..3]`) given in the bit mask `axes`.
  [[nodiscard]] std::array<double, 4> modal_target(unsigned axes, const double* value,
                                                   std::array<double, 4>& new_gcode) const;
  // Klipper state commands (klipper_state.cpp): SAVE/RESTORE_GCODE_STATE, ACTIVATE_EXTRUDER,
  // EXCLUDE_OBJECT_* (the move transform) and SET_DUAL_CARRIAGE / *_DUAL_CARRIAGE_STATE.
  /// True when `name` is one of those commands and it was handled.
  bool handle_klipper_state(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void handle_bed_mesh(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void save_gcode_state(const Command& cmd, std::uint64_t line_no);
  void restore_gcode_state(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void set_gcode_offset(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void exclude_object_command(const Command& cmd, std::uint64_t line_no);
  /// Klipper's exclude_object move transform: the move to `target` (pre-transform machine
  /// coordinates) made, shifted or skipped.
  void exclude_move(const std::array<double, 4>& target, const MoveRequest& proto, EventSink& sink);
  /// After G28 / SET_KINEMATIC_POSITION changed pos_ on the axes in `axes` (bit mask).
  void after_position_set(unsigned axes);
  void dual_carriage_command(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  void set_stepper_carriages(const Command& cmd, std::uint64_t line_no, EventSink& sink);
  /// G28 of a dual-carriage axis (pair index): both carriages home, carriage 0 ends active.
  void home_dual_carriage(std::size_t pair);
  /// Klipper's get_kin_range for the axis of a pair, sent to the sink as its range.
  void send_carriage_range(std::size_t pair, std::uint64_t line_no, EventSink& sink);
  void update_path_choice();
  void note_unknown(std::string_view name, std::uint64_t line_no);
  void note_ignored(std::string_view name);
  [[noreturn]] void fail(std::uint64_t line_no, std::uint32_t col, const std::string& msg) const;

  InterpreterOptions opt_;
  std::string source_;
  // Modal state.
  std::array<double, 4> pos_{};         // machine position X Y Z E
  std::array<double, 4> gcode_pos_{};   // position as the file sees it (after G92)
  bool absolute_xyz_ = true;
  bool absolute_e_ = true;
  double unit_mm_ = 1.0;                // 25.4 after G20
  double feed_mm_s_ = 25.0;             // Klipper's initial 1500 mm/min
  double speed_factor_ = 1.0;           // M220
  double extrude_factor_ = 1.0;         // M221
  int arc_plane_ = 17;
  bool retracted_ = false;
  bool soft_endstops_ = false;          // any soft endstop configured
  bool soft_enabled_ = true;            // M211 S0 switches the soft endstops off
  double hop_mm_ = 0.0;         // Z raised by G10 and not yet lowered by G11
  double hop_from_z_mm_ = 0.0;  // machine Z before that hop
  unsigned homed_axes_ = 0;       // bit 0 X, 1 Y, 2 Z: homed by G28 (printer.toolhead.homed_axes; Marlin's soft endstops apply)
  std::array<double, 3> heater_target_c_{};  // hotend, bed, chamber
  // SAVE_GCODE_STATE (Klipper gcode_move.py): what RESTORE_GCODE_STATE gives back. Base
  // position = machine - gcode position (XYZ); E as the file's own coordinate.
  struct SavedGcodeState {
    bool absolute_xyz = true, absolute_e = true;
    std::array<double, 4> position_mm{}, gcode_position_mm{};
    double feed_mm_s = 25.0, speed_factor = 1.0, extrude_factor = 1.0;
    std::array<double, 4> homing_offset_mm{};
  };
  std::array<double, 4> homing_offset_mm_{};  // SET_GCODE_OFFSET (Klipper's homing_position)
  std::map<std::string, SavedGcodeState, std::less<>> saved_states_;
  std::string active_extruder_ = "extruder";  // ACTIVATE_EXTRUDER (printer.toolhead.extruder)
  // Klipper exclude_object.py: the objects, and its move transform once registered.
  struct ExcludeObjects {
    std::vector<std::string> objects, excluded;  // sorted, upper case
    std::optional<std::string> current;
    bool transform = false;     // registered by the first exclusion
    bool bypass = false;        // set_exclusion_bypassed
    bool in_excluded_region = false;
    int initial_extrusion_moves = 5;
    std::array<double, 4> toolhead_mm{};  // where the toolhead is (pos_ is gcode_move's)
    std::array<double, 4> offset_mm{}, last_extruded_mm{}, last_excluded_mm{};
    double max_extruded_mm = 0.0, max_excluded_mm = 0.0, extruder_adj_mm = 0.0;
    std::uint64_t skipped_moves = 0;
    std::vector<ExcludedObject> ever_excluded;
  } exclude_;
  // Klipper idex_modes.py: per carriage its mode and axis transform (carriage position =
  // toolhead position * scale + offset; an inactive carriage has scale 0).
  enum class CarriageMode : std::uint8_t { inactive, primary, copy, mirror };
  struct Carriage {
    CarriageMode mode = CarriageMode::inactive;
    double scale = 0.0, offset_mm = 0.0;
  };
  std::vector<std::array<Carriage, 2>> carriages_;  // one per opt_.dual_carriages pair
  std::map<std::string, std::vector<std::array<Carriage, 2>>, std::less<>> saved_carriages_;
  std::map<std::string, std::array<double, 4>, std::less<>> saved_carriage_pos_;
  std::map<std::string, std::string, std::less<>> stepper_carriages_;  // SET_STEPPER_CARRIAGES
  CommandExpander* expander_ = nullptr;
  bool general_path_only_ = false;  // the expander may take G0/G1
  Annotations notes_;
  std::vector<UnknownCommand> unknown_;
  std::unordered_map<std::string, std::size_t> unknown_index_;  // name -> unknown_ (constant-time)
  std::map<std::string, std::uint64_t> ignored_;
  std::uint64_t skipped_lines_ = 0;
  Command cmd_;
  Params params_;
  ParseIssue issue_;
};

}  // namespace amctl::gcode
