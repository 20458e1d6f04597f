// Which commands amctl knows to take no motion time (ignored) or unpredictable time
// (untimed): the tables of the interpreter's dispatch (interpreter.cpp, extended.cpp).
#include "command_table.hpp"

#include <algorithm>
#include <iterator>

#include "internal.hpp"

namespace amctl::gcode::detail {
namespace {

// SAVE_/RESTORE_GCODE_STATE, SET_GCODE_OFFSET, ACTIVATE_EXTRUDER, EXCLUDE_OBJECT* and the dual-carriage commands
// are modelled in klipper_state.cpp (ACTIVATE_EXTRUDER and, without [exclude_object] in a
// printer.cfg, EXCLUDE_OBJECT* are still counted here as before).
constexpr std::string_view kIgnoredExtended[] = {
    "SET_PRESSURE_ADVANCE", "SET_INPUT_SHAPER", "SET_PRINT_STATS_INFO", "RESPOND",
    "SET_FAN_SPEED",
    "SET_LED", "SET_PIN", "SET_IDLE_TIMEOUT", "SET_STEPPER_ENABLE", "SET_TMC_CURRENT",
    "SET_SKEW", "SKEW_PROFILE", "BED_MESH_PROFILE", "BED_MESH_CLEAR", "SET_GCODE_VARIABLE",
    "UPDATE_DELAYED_GCODE", "SET_EXTRUDER_ROTATION_DISTANCE", "SYNC_EXTRUDER_MOTION",
    "SET_FILAMENT_SENSOR", "STATUS", "ECHO", "M117",
    "SET_DISPLAY_TEXT", "ACCELEROMETER_MEASURE", "ACCELEROMETER_QUERY"};
constexpr std::string_view kUntimedExtended[] = {
    "BED_MESH_CALIBRATE", "QUAD_GANTRY_LEVEL", "Z_TILT_ADJUST", "PROBE", "PROBE_ACCURACY",
    "PROBE_CALIBRATE", "SCREWS_TILT_CALCULATE", "PAUSE", "CALIBRATE_Z", "SHAPER_CALIBRATE",
    "TEST_RESONANCES", "PID_CALIBRATE", "DELTA_CALIBRATE"};

}  // namespace

// Commands understood to have no effect on motion time.
bool is_ignored_word(char letter, int code) {
  if (letter == 'T') return true;  // tool select: single-extruder time model
  if (letter == 'G') {
    switch (code) {
      case 21: case 17: case 18: case 19: case 90: case 91: case 94: case 31: case 53: case 54:
      case 55: case 56: case 57: case 58: case 59:
        return true;
      default:
        return false;
    }
  }
  if (letter == 'M') {
    // Sorted: housekeeping, reporting, settings, SD card, LEDs, sound, leveling switches.
    static constexpr int kCodes[] = {
        17,  18,  21,  22,  23,  24,  25,  27,  28,  29,  30,  31,  32,  33,  34,  39,  42,
        43,  75,  76,  77,  78,  80,  81,  84,  85,  92,  105, 108, 110, 111, 112, 113, 114,
        115, 117, 118, 119, 120, 121, 122, 145, 149, 150, 155, 163, 164, 193, 200, 209, 211,
        217, 218, 250, 255, 280, 290, 300, 301, 302, 303, 304, 305, 306, 307, 350, 351, 355,
        380, 381, 401, 402, 403, 404, 405, 406, 407, 410, 412, 413, 420, 428, 486, 500, 501,
        502, 503, 504, 530, 531, 532, 540, 551, 552, 553, 554, 555, 569, 570, 571, 572, 573,
        574, 575, 577, 579, 581, 582, 584, 585, 591, 592, 593, 594, 595, 596, 597, 598, 603,
        605, 665, 666, 669, 671, 672, 701, 702, 703, 815, 851, 860, 861, 862, 863, 864, 865,
        866, 867, 868, 869, 876, 890, 891, 900, 906, 907, 911, 912, 913, 914, 915, 917, 918,
        919, 920, 928, 997, 999};
    return std::binary_search(std::begin(kCodes), std::end(kCodes), code);
  }
  return false;
}

// Commands that take real time amctl cannot predict (homing, probing, user interaction).
bool is_untimed_word(char letter, int code) {
  if (letter == 'G') {
    switch (code) {
      case 28: case 29: case 30: case 32: case 33: case 34: case 35: case 76: case 80: case 81:
      case 425:
        return true;
      default:
        return false;
    }
  }
  if (letter == 'M') {
    switch (code) {
      case 0: case 1: case 48: case 125: case 226: case 600: case 601: case 602: case 1001:
        return true;
      default:
        return false;
    }
  }
  return false;
}

bool is_ignored_extended(std::string_view name) {
  return std::any_of(std::begin(kIgnoredExtended), std::end(kIgnoredExtended),
                     [&](std::string_view n) { return iequals(name, n); });
}

bool is_untimed_extended(std::string_view name) {
  return std::any_of(std::begin(kUntimedExtended), std::end(kUntimedExtended),
                     [&](std::string_view n) { return iequals(name, n); });
}

}  // namespace amctl::gcode::detail
