#pragma once
// Seed 000, tables 3.2/3.3: the base case (w = 100 rad/s, zeta = 0.5, a = 5000 mm/s^2,
// v = 100 mm/s, h = 5 ms) and one-at-a-time variations, each planned twice on the seed's
// L-shaped path (10 mm in X then 10 mm in Y): with Klipper's look-ahead junction speed and
// with the thesis's full stop at the corner. `amctl sweep` (docs/dynamics_seed000_sweep.md).
#include <string>
#include <vector>

#include "amctl/core/json.hpp"

namespace amctl::dynamics {

struct Seed000Case {
  std::string name;
  double w_rad_s = 100, zeta = 0.5, accel_mm_s2 = 5000, v_mm_s = 100, h_s = 0.005;
};

/// The seed's cases in table order.
[[nodiscard]] std::vector<Seed000Case> seed000_cases();

struct Seed000Row {
  Seed000Case c;
  bool lookahead = true;           ///< false: zero junction speed (the thesis)
  double junction_speed_mm_s = 0.0;
  double motion_time_s = 0.0;
  std::size_t samples = 0;         ///< the seed's sample count (trajectory::sample_seed000)
  double max_contour_error_mm = 0.0;
  double rms_contour_error_mm = 0.0;
  double max_corner_overshoot_mm = 0.0;
  double final_residual_vibration_mm = 0.0;
  double compute_time_s = 0.0;
};

/// Both junction models for every case; square_corner_velocity_mm_s for the look-ahead runs.
[[nodiscard]] std::vector<Seed000Row> seed000_sweep(double square_corner_velocity_mm_s);

/// `amctl sweep --json`.
[[nodiscard]] Json to_json(const std::vector<Seed000Row>& rows, double square_corner_velocity_mm_s);

}  // namespace amctl::dynamics
