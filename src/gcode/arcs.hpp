#pragma once
// G2/G3 linearisation rules, internal to the gcode module (Interpreter::do_arc is in
// arcs.cpp). docs/gcode.md, "Arcs", has the equations.
#include "amctl/gcode/interpreter.hpp"

namespace amctl::gcode::detail {

/// Number of chords (>= 1, as a double: the caller divides by it) for an arc of
/// `length_mm` (helical length) sweeping `sweep_rad` (either sign; 2 pi for a full circle,
/// `full_circle` when the start is the end) requested at `speed_mm_s`.
double arc_segment_count(const InterpreterOptions& o, double length_mm, double sweep_rad,
                         bool full_circle, double speed_mm_s);

}  // namespace amctl::gcode::detail
