#pragma once
// The interpreter's hook for commands defined outside it (Klipper's [gcode_macro]): before
// its built-in handling, the interpreter offers every command that is not a plain move to a
// CommandExpander, which may replace it by lines of G-code (run in its place, each reported
// at the calling line) or by the built-in command it renames. The macro module implements it
// (amctl/macro/expander.hpp); the gcode module knows only this interface.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/gcode/command.hpp"

namespace amctl::gcode {

/// What the interpreter knows at a command, as a macro may read it (Klipper's
/// printer.toolhead, printer.gcode_move and heater objects).
struct InterpreterState {
  std::array<double, 4> position_mm{};        ///< machine X Y Z E
  std::array<double, 4> gcode_position_mm{};  ///< as the file sees it (after G92)
  bool absolute_coordinates = true;           ///< G90
  bool absolute_extrude = true;               ///< M82
  double feed_mm_min = 1500.0;                ///< last F, without the M220 factor
  double speed_factor = 1.0;                  ///< M220 S / 100
  double extrude_factor = 1.0;                ///< M221 S / 100
  unsigned homed_axes = 0;                    ///< bit 0 X, 1 Y, 2 Z (G28, SET_KINEMATIC_POSITION)
  double hotend_target_c = 0.0;               ///< last M104/M109 (or SET_HEATER_TEMPERATURE)
  double bed_target_c = 0.0;                  ///< last M140/M190
  double chamber_target_c = 0.0;              ///< last M141/M191
  std::array<double, 4> homing_origin_mm{};   ///< SET_GCODE_OFFSET (gcode_move.homing_origin)
  std::string active_extruder = "extruder";   ///< ACTIVATE_EXTRUDER (printer.toolhead.extruder)
  /// Klipper printer.exclude_object, present only with [exclude_object] (names upper case).
  bool exclude_object = false;
  std::vector<std::string> objects, excluded_objects;
  std::optional<std::string> current_object;
};

/// What an expander made of one command.
struct Expansion {
  enum class Kind : std::uint8_t {
    none,     ///< not its command: the interpreter handles it
    script,   ///< run `text` (lines separated by '\n', maybe empty) instead; then end_script(id)
    builtin,  ///< run `text`, a built-in command renamed away (rename_existing), as built-in
    done      ///< its command, fully handled or skipped (the expander recorded why)
  };
  Kind kind = Kind::none;
  std::string text;
  std::uint32_t id = 0;  ///< script: passed back to end_script
  std::string name;      ///< script: the macro's name, for messages
};

class CommandExpander {
 public:
  virtual ~CommandExpander() = default;
  /// `cmd` parsed from `line` (as written) at G-code line `line_no`.
  virtual Expansion expand(const Command& cmd, std::string_view line, std::uint64_t line_no,
                           const InterpreterState& state) = 0;
  /// The script of expansion `id` has run to its end.
  virtual void end_script(std::uint32_t id) { (void)id; }
  /// True when G0/G1 may be macros: the interpreter then reads every line the general way.
  [[nodiscard]] virtual bool expands_moves() const { return false; }
};

}  // namespace amctl::gcode
