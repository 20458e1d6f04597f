// Firmware retraction: G10/G11 and their settings M207/M208 (Klipper [firmware_retraction],
// Marlin FWRETRACT). Klipper's SET_RETRACTION is in extended.cpp with the other extended
// commands.
#include <algorithm>

#include "amctl/gcode/interpreter.hpp"

namespace amctl::gcode {

void Interpreter::firmware_retraction(bool retract, const Params& p, std::uint64_t line_no,
                                      EventSink& sink) {
  if (retract && (p.has('L') || p.has('P'))) {  // G10 L2/L20 P: coordinate offsets
    note_ignored("G10 L");
    return;
  }
  // A second G10 (or G11) in a row does nothing, as in Klipper and Marlin.
  if (retract == retracted_) return;
  retracted_ = retract;
  auto t = pos_;
  if (retract) {
    t[3] -= opt_.retract_length_mm;
    if (opt_.retract_length_mm > 0) emit_move(t, opt_.retract_speed_mm_s, line_no, sink, false, true);
  } else {
    t[3] += opt_.retract_length_mm + opt_.unretract_extra_length_mm;
    if (t[3] != pos_[3]) emit_move(t, opt_.unretract_speed_mm_s, line_no, sink, false, true);
  }
}

void Interpreter::set_firmware_retraction(int code, const Params& p) {
  if (code == 207) {  // Marlin/RRF: S length [mm], F speed [mm/min]
    if (p.has('S')) opt_.retract_length_mm = std::max(0.0, p.get('S'));
    if (p.has('F') && p.get('F') > 0) opt_.retract_speed_mm_s = p.get('F') / 60.0;
    return;
  }
  // M208: S extra length on recovery [mm], F recovery speed [mm/min]
  if (p.has('S')) opt_.unretract_extra_length_mm = p.get('S');
  if (p.has('F') && p.get('F') > 0) opt_.unretract_speed_mm_s = p.get('F') / 60.0;
}

}  // namespace amctl::gcode
