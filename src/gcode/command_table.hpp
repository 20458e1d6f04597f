#pragma once
// The interpreter's lists of commands that need no model: internal to the gcode module.
#include <string_view>

namespace amctl::gcode::detail {

/// G/M/T words understood to have no effect on motion time (M117, G21, T0, ...).
bool is_ignored_word(char letter, int code);
/// G/M words that take real time amctl cannot predict (homing, probing, user interaction).
bool is_untimed_word(char letter, int code);
/// The same for Klipper extended commands (case-insensitive names).
bool is_ignored_extended(std::string_view name);
bool is_untimed_extended(std::string_view name);

}  // namespace amctl::gcode::detail
