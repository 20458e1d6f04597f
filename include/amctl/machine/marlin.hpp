#pragma once
// A Marlin printer as its users have it: the settings report of M503 (as a terminal, OctoPrint
// or Pronterface shows it), or the firmware's Configuration.h (with Configuration_adv.h beside
// it). load_machine() recognises both by content; docs/machine.md, "Marlin printers", lists
// what is read.
#include <string>
#include <string_view>

#include "amctl/machine/machine.hpp"

namespace amctl::machine {

/// True if `text` holds M503 output: at least two of M92, M201, M203, M204, M205 as report
/// lines (after any "Recv:", "echo:" or timestamp prefix of a terminal log).
bool looks_like_m503(std::string_view text);

/// A Marlin machine from M503 output. Read: M92 (steps/mm, with 16 microsteps of 200-step
/// motors assumed: the steps/mm are exact), M201, M203, M204 (P print, R retract, T travel;
/// S = print and travel on older firmware), M205 (B us, S, T, X Y Z E classic jerk, J junction
/// deviation), M200 D, M207 / M208 (firmware retraction, F in mm/min), M593 (Marlin's ZV input
/// shaper), M906 (TMC run current, mA). Reported and accepted without effect on the plan: M851
/// (probe offset), M900 (linear advance), M420, M145, M301/M304, M206, M211, M149, M413, M414,
/// M569, M913, M914, M122... printer.max_accel is M204 P (S on older firmware); the toolhead
/// velocity is the XY feedrate limit. M201, M203, M204 and M205 are required; a delta (M665)
/// is refused. Lines named "Send:" in a log are commands sent, not the report: skipped.
/// Errors name source_name:line:column.
Machine parse_marlin_m503(std::string_view text, const std::string& source_name);

/// True if `text` looks like a C header of #define lines (Marlin's Configuration.h).
bool looks_like_marlin_configuration(std::string_view text);

/// A Marlin machine from Configuration.h and, if given, Configuration_adv.h: the #define lines
/// that are not commented out (conditionals are not evaluated: Marlin's motion limits are not
/// inside any). Read: DEFAULT_AXIS_STEPS_PER_UNIT, DEFAULT_MAX_FEEDRATE,
/// DEFAULT_MAX_ACCELERATION, DEFAULT_ACCELERATION, DEFAULT_RETRACT_ACCELERATION,
/// DEFAULT_TRAVEL_ACCELERATION, CLASSIC_JERK with DEFAULT_XJERK / YJERK / ZJERK / EJERK, else
/// JUNCTION_DEVIATION_MM, S_CURVE_ACCELERATION, COREXY / COREXZ / MARKFORGED_XY,
/// DEFAULT_NOMINAL_FILAMENT_DIA, INPUT_SHAPING_X / _Y with SHAPING_FREQ_* and SHAPING_ZETA_*;
/// from Configuration_adv.h DEFAULT_MINSEGMENTTIME, DEFAULT_MINIMUMFEEDRATE,
/// DEFAULT_MINTRAVELFEEDRATE, BLOCK_BUFFER_SIZE and the arc settings. A file defining none of
/// the motion limits (DEFAULT_MAX_FEEDRATE, DEFAULT_MAX_ACCELERATION, DEFAULT_ACCELERATION) is
/// an error, as is a delta.
Machine parse_marlin_configuration(std::string_view text, const std::string& source_name,
                                   std::string_view adv_text = {},
                                   const std::string& adv_name = {});

}  // namespace amctl::machine
