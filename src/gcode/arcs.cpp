// G2/G3: arcs in the G17/G18/G19 plane, I/J/K centre or R radius forms, linearised into
// chords (Klipper [gcode_arcs], Marlin ARC_SUPPORT; docs/gcode.md, "Arcs").
#include "arcs.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include <fmt/format.h>

namespace amctl::gcode {

double detail::arc_segment_count(const InterpreterOptions& o, double length_mm,
                                 double sweep_rad, bool full_circle, double speed_mm_s) {
  double seg_len = o.mm_per_arc_segment;
  if (o.arc_segments_per_second > 0.0) seg_len = speed_mm_s / o.arc_segments_per_second;
  if (o.min_arc_segment_mm > 0.0) seg_len = std::max(seg_len, o.min_arc_segment_mm);
  if (o.max_arc_segment_mm > 0.0) seg_len = std::min(seg_len, o.max_arc_segment_mm);
  double segments = std::max(1.0, std::floor(length_mm / seg_len));
  if (o.min_circle_segments > 0) {
    // Marlin MIN_CIRCLE_SEGMENTS (Marlin/src/gcode/motion/G2_G3.cpp, plan_arc): n segments
    // for a full circle, ceil(n * sweep / 2 pi) for a part of one. The 1e-9 keeps exact
    // fractions exact: a quarter of 72 is 18, not 19 from the rounding of atan2 and pi.
    const double n = o.min_circle_segments;
    const double least =
        full_circle ? n
                    : std::max(1.0, std::ceil(n * std::fabs(sweep_rad) / (2.0 * std::numbers::pi) - 1e-9));
    if (least > segments) {
      segments = least;
      // Marlin then gives up segments that would be shorter than MIN_ARC_SEGMENT_MM.
      if (o.min_arc_segment_mm > 0.0 && length_mm / segments < o.min_arc_segment_mm) {
        segments = std::max(1.0, std::floor(length_mm / o.min_arc_segment_mm));
      }
    }
  }
  return segments;
}

void Interpreter::do_arc(const Command& cmd, const Params& p, bool clockwise,
                         std::uint64_t line_no, EventSink& sink) {
  require_numbers(p, line_no);
  // Klipper refuses relative arcs; Marlin allows them: targets are then relative.
  apply_feed(p, line_no);
  // Plane axes: (alpha, beta) in the plane, helical axis normal to it.
  std::size_t a0 = 0, a1 = 1, ah = 2;
  char c0 = 'I', c1 = 'J';
  if (arc_plane_ == 18) { a0 = 0; a1 = 2; ah = 1; c0 = 'I'; c1 = 'K'; }
  if (arc_plane_ == 19) { a0 = 1; a1 = 2; ah = 0; c0 = 'J'; c1 = 'K'; }

  std::array<double, 4> new_gcode;
  const std::array<double, 4> target = target_of(p, new_gcode);
  const double e_total = target[3] - pos_[3];
  double off0 = 0.0, off1 = 0.0;  // center - start, in the plane
  const double p0 = pos_[a0], q0 = pos_[a1], p1 = target[a0], q1 = target[a1];
  if (p.has('R')) {
    const double r = p.get('R') * unit_mm_;
    const double dx = p1 - p0, dy = q1 - q0;
    const double d = std::hypot(dx, dy);
    if (d == 0.0 || r == 0.0) {
      fail(line_no, p.column['R' - 'A'],
           "G2/G3 R form needs a target different from the start and R != 0");
    }
    // Centre on the perpendicular bisector of the chord at distance h from its midpoint.
    // Counter-clockwise with R > 0 (arc < 180 degrees) puts the centre left of the chord.
    double h2 = r * r - 0.25 * d * d;
    if (h2 < 0.0) {
      if (std::fabs(r) * 2.0 < d * (1.0 - 1e-3)) {
        fail(line_no, p.column['R' - 'A'],
             fmt::format("G2/G3 radius R={} is smaller than half the chord ({} mm)", r, 0.5 * d));
      }
      h2 = 0.0;
    }
    const double side = ((clockwise ? -1.0 : 1.0) * (r < 0 ? -1.0 : 1.0));
    const double h = std::sqrt(h2);
    const double cx = 0.5 * (p0 + p1) + side * h * (-dy / d);
    const double cy = 0.5 * (q0 + q1) + side * h * (dx / d);
    off0 = cx - p0;
    off1 = cy - q0;
  } else {
    off0 = p.get_or(c0, 0.0) * unit_mm_;
    off1 = p.get_or(c1, 0.0) * unit_mm_;
    if (off0 == 0.0 && off1 == 0.0) {
      fail(line_no, cmd.args_column,
           fmt::format("{} without a centre offset, expected {} or {} (the centre) or R (a radius)",
                       cmd.name, c0, c1));
    }
  }
  // Angular travel from start radius vector to end radius vector.
  const double rs0 = -off0, rs1 = -off1;  // start relative to centre
  const double cx = p0 + off0, cy = q0 + off1;
  const double re0 = p1 - cx, re1 = q1 - cy;
  double angle = std::atan2(rs0 * re1 - rs1 * re0, rs0 * re0 + rs1 * re1);
  if (angle < 0.0) angle += 2.0 * std::numbers::pi;
  if (clockwise) angle -= 2.0 * std::numbers::pi;
  if (angle == 0.0 && p0 == p1 && q0 == q1) angle = clockwise ? -2.0 * std::numbers::pi : 2.0 * std::numbers::pi;
  const double radius = std::hypot(rs0, rs1);
  const double linear = target[ah] - pos_[ah];
  const double flat = radius * std::fabs(angle);
  const double travel = linear != 0.0 ? std::hypot(flat, linear) : flat;
  const bool full_circle = p0 == p1 && q0 == q1;
  const double segments_d =
      detail::arc_segment_count(opt_, travel, angle, full_circle, feed_mm_s_ * speed_factor_);
  if (segments_d > 1e7) {
    fail(line_no, cmd.args_column,
         fmt::format("arc of {} mm would need {} segments: radius or segment length is absurd",
                     travel, segments_d));
  }
  const auto segments = static_cast<std::int64_t>(segments_d);
  const double start_e = pos_[3];
  const std::array<double, 4> start = pos_;
  for (std::int64_t i = 1; i <= segments; ++i) {
    std::array<double, 4> t;
    if (i == segments) {
      t = target;
      t[3] = start_e + e_total;
    } else {
      const double th = angle * static_cast<double>(i) / segments_d;
      const double c = std::cos(th), s = std::sin(th);
      t = start;
      t[a0] = cx + rs0 * c - rs1 * s;
      t[a1] = cy + rs0 * s + rs1 * c;
      t[ah] = start[ah] + linear * static_cast<double>(i) / segments_d;
      t[3] = start_e + e_total * static_cast<double>(i) / segments_d;
    }
    // Marlin clamps every segment (plan_arc -> apply_motion_limits); the file's position
    // follows the clamp of the last one.
    const bool clamped = soft_endstops_ && soft_clamp(t, i == segments ? &new_gcode : nullptr);
    emit_move(t, feed_mm_s_ * speed_factor_, line_no, sink, true, false, clamped);
  }
  gcode_pos_ = new_gcode;
}

}  // namespace amctl::gcode
