#pragma once
// Synthetic inputs shared by the benchmarks: deterministic, so runs compare.
#include <array>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/velocity_profile.hpp"
#include "amctl/trajectory/build.hpp"

namespace amctl::bench {

/// Slicer-like G-code: layers of circular perimeters (short chords, relative E) joined by
/// travels, the shape of real perimeter-heavy files. `moves` extrusion moves in all.
inline std::string synthetic_gcode(std::size_t moves) {
  std::string g = "M83\nG1 F3000\n";
  g.reserve(moves * 34);
  std::size_t n = 0;
  int layer = 0;
  while (n < moves) {
    g += fmt::format(";LAYER_CHANGE\n;Z:{:.2f}\nG1 Z{:.2f} F600\n;TYPE:Perimeter\n", 0.2 * (layer + 1),
                     0.2 * (layer + 1));
    for (int ring = 0; ring < 10 && n < moves; ++ring) {
      const double r = 5.0 + 2.0 * ring;
      g += fmt::format("G1 X{:.3f} Y100.000 F9000\nG1 F2700\n", 100.0 + r);
      for (int k = 1; k <= 120 && n < moves; ++k, ++n) {
        const double a = 2.0 * std::numbers::pi * k / 120.0;
        g += fmt::format("G1 X{:.3f} Y{:.3f} E{:.5f}\n", 100.0 + r * std::cos(a),
                         100.0 + r * std::sin(a), 0.0335 * r * 2.0 * std::numbers::pi / 120.0);
      }
    }
    ++layer;
  }
  return g;
}

/// A synthetic print of 7200 s of motion, timed by hand (not planned): segments of 0.3..20 mm
/// (log-uniform) turning by random angles inside a 10..290 mm square, 150 mm/s, 5000 mm/s^2,
/// junction speed from a square-corner-velocity-like rule. `seed` and `start` pick one.
inline std::vector<plan::PlannedMove> synthetic_two_hour_print(std::uint64_t seed,
                                                              std::array<double, 4> start) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::vector<plan::PlannedMove> out;
  std::array<double, 4> at = start;
  double t = 0.0, v = 0.0, heading = 0.0;
  const double accel = 5000.0, vmax = 150.0;
  std::uint64_t line = 1;
  while (t < 7200.0) {
    const double len = 0.3 * std::pow(20.0 / 0.3, u01(rng));
    const double turn = (u01(rng) < 0.3) ? (u01(rng) - 0.5) * 3.2 : (u01(rng) - 0.5) * 0.4;
    heading += turn;
    std::array<double, 4> to = at;
    to[0] += len * std::cos(heading);
    to[1] += len * std::sin(heading);
    if (to[0] < 10 || to[0] > 290 || to[1] < 10 || to[1] > 290) {
      heading += 3.14159;
      continue;
    }
    to[3] += 0.03 * len;
    // junction speed into the next move: 5 mm/s at sharp turns, more when nearly straight
    const double jv = std::min(vmax, 5.0 / std::max(0.05, std::abs(std::sin(0.5 * turn))));
    const double reach = plan::max_reachable_speed_mm_s(plan::VelocityProfile::trapezoid, v, len, accel);
    const double brake = std::sqrt(std::max(0.0, v * v - 2.0 * accel * len));
    trajectory::MoveSpec spec{to, vmax, std::max(brake, std::min({jv, reach, vmax})), line++,
                              static_cast<std::int32_t>(t / 60.0), 0};
    out.push_back(trajectory::timed_move(at, spec, v, t, accel, plan::VelocityProfile::trapezoid, 0.0));
    t = out.back().end_time_s();
    v = out.back().end_v_mm_s;
    at = to;
  }
  return out;
}

}  // namespace amctl::bench
