// Firmware retraction: G10/G11 and their settings M207/M208 (Klipper [firmware_retraction],
// Marlin FWRETRACT). Klipper's SET_RETRACTION is in extended.cpp with the other extended
// commands.
#include <algorithm>

#include "amctl/gcode/interpreter.hpp"
#include "internal.hpp"

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
  // Marlin's order (Marlin/src/feature/fwretract.cpp, FWRetract::retract): G10 retracts E,
  // then raises Z by RETRACT_ZRAISE at the Z axis's maximum feedrate (once: no second hop
  // while one is in force; hops of 0.01 mm or less are ignored); G11 first lowers Z by the
  // hop in force, then recovers E. The hop is an offset on the machine position, so the moves
  // in between travel raised, as in Marlin.
  if (retract) {
    auto t = pos_;
    t[3] -= opt_.retract_length_mm;
    if (opt_.retract_length_mm > 0) emit_move(t, opt_.retract_speed_mm_s, line_no, sink, false, true);
    if (hop_mm_ == 0.0 && opt_.lift_z_mm > 0.01) {
      hop_mm_ = opt_.lift_z_mm;
      hop_from_z_mm_ = pos_[2];
      auto z = pos_;
      z[2] += hop_mm_;
      emit_move(z, opt_.lift_z_speed_mm_s, line_no, sink, false, true);
    }
    return;
  }
  if (hop_mm_ != 0.0) {
    auto z = pos_;
    // Back to the very Z it left when nothing moved Z since (no rounding drift), else down
    // by the hop.
    z[2] = pos_[2] == hop_from_z_mm_ + hop_mm_ ? hop_from_z_mm_ : pos_[2] - hop_mm_;
    hop_mm_ = 0.0;
    emit_move(z, opt_.lift_z_speed_mm_s, line_no, sink, false, true);
  }
  auto t = pos_;
  t[3] += opt_.retract_length_mm + opt_.unretract_extra_length_mm;
  if (t[3] != pos_[3]) emit_move(t, opt_.unretract_speed_mm_s, line_no, sink, false, true);
}

void Interpreter::set_firmware_retraction(int code, const Params& p, std::uint64_t line_no) {
  // F: Marlin ignores a value <= 0; a positive one must be a feedrate a machine can have.
  if (p.has('F') && p.get('F') > 0 && !in_range(detail::kFeedRange, p.get('F'))) {
    fail(line_no, p.column['F' - 'A'],
         detail::out_of_range(fmt::format("M{} F", code), detail::kFeedRange, p.get('F')));
  }
  if (code == 207) {  // Marlin/RRF: S length [mm], F speed [mm/min], Z hop [mm]
    if (p.has('S')) opt_.retract_length_mm = std::max(0.0, p.get('S'));
    if (p.has('F') && p.get('F') > 0) opt_.retract_speed_mm_s = p.get('F') / 60.0;
    // Marlin reads Z in the current units (G20 inches); a negative hop means none.
    if (p.has('Z')) opt_.lift_z_mm = std::max(0.0, p.get('Z') * unit_mm_);
    return;
  }
  // M208: S extra length on recovery [mm], F recovery speed [mm/min]
  if (p.has('S')) opt_.unretract_extra_length_mm = p.get('S');
  if (p.has('F') && p.get('F') > 0) opt_.unretract_speed_mm_s = p.get('F') / 60.0;
}

}  // namespace amctl::gcode
