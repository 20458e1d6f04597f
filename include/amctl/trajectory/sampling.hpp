#pragma once
// Fixed-step sampling of a trajectory.
//  - sample_uniform: the exact state on a uniform grid t0, t0 + h, ...
//  - sample_seed000: the thesis's interpolation (seed 000, eqs 3.7-3.10): every phase of
//    every move is cut into N = ceil(dt/h - 1) steps of h plus a last step dt - N h, the
//    displacement of each step is v dt + a dt^2 / 2 (v = speed at the step start) and
//    positions are the cumulative sum. For constant-accel phases this agrees with the exact
//    evaluation to round-off; for higher-degree pieces the step displacement is the exact
//    difference s(tau + dt) - s(tau) (the thesis only had trapezoids).
#include <span>
#include <vector>

#include "amctl/plan/planned_move.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::trajectory {

struct PathSample {
  double t_s = 0.0;
  std::array<double, kAxes> pos_mm{};
  double speed_mm_s = 0.0;          ///< path speed
  std::uint64_t line = 0;           ///< G-code line of the move being executed
};

/// Uniform grid over [t0, t1] (inclusive of t0; t1 included when it lies on the grid).
/// Throws amctl::Error for step_s <= 0 or t1 < t0 ("empty range").
[[nodiscard]] std::vector<AxisState> sample_uniform(const Trajectory& traj, double step_s,
                                                    double t0_s, double t1_s);

/// Seed 000 (3.7-3.10) interpolation of the whole plan, starting with a sample at the first
/// move's start. Throws amctl::Error for step_s <= 0.
[[nodiscard]] std::vector<PathSample> sample_seed000(std::span<const plan::PlannedMove> moves,
                                                     double step_s);

/// N of (3.7) with a relative tolerance of 1e-9 on dt/h being an integer, so that a phase
/// of exactly k steps gives k - 1 full steps and one last step of h (as 3.7-3.8 intend).
[[nodiscard]] long seed000_full_steps(double dt_s, double step_s);

}  // namespace amctl::trajectory
