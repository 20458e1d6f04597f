#pragma once
// Feedforward compensation of the belt model (seed 000, issue 10): the motor-side (base)
// command x_b(t) per axis such that the simulated nozzle x(t) follows the planned path.
//
// Methods (docs/compensation.md):
//  - invert: the exact inverse of the modal belt model for the planned trajectory. With
//    G(s) = X/X_b = 1 - sum_i g_i s^2 / D_i(s), D_i = s^2 + 2 z_i w_i s + w_i^2, the command is
//        x_b = x + H(s) x'',  H(s) = [sum_i g_i prod_{j!=i} D_j] / N(s),  N = D - s^2 sum(...)
//    (one mode: x_b = x + f / (2 z w), f' = -(w / 2z) f + x''), integrated exactly on the
//    piecewise-polynomial plan. Where the plan's steps (acceleration steps of a trapezoid,
//    velocity jumps at corners) make the inverse demand unbounded base acceleration, the
//    status says so.
//  - fbf: filtered basis functions (Ramani et al. 2017), uniform B-splines filtered through
//    the model, weights by banded least squares on the tracking error; lpfbf: the same over
//    overlapping windows, streamed; rfbf: least squares over the model and four detuned ones.
//  - collocation: Hermite-Simpson direct collocation (seed 000 section 2.2) of the command
//    and the model's states, solved by IPOPT with exact sparse derivatives: mean squared
//    tracking error plus effort, the bound |(x_b'', y_b'')| <= max_base_accel_mm_s2 enforced,
//    overlapping windows so that the cost grows linearly with the path.
// Every command is checked by simulating it (dynamics::Simulator on the sampled command,
// linear between samples) through the plant model; the reported errors are the simulated ones.
#include <cstdint>
#include <functional>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/compensation/command_table.hpp"
#include "amctl/core/output.hpp"
#include "amctl/dynamics/model.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/plan/stream.hpp"

namespace amctl::compensation {

enum class Method { invert, fbf, lpfbf, rfbf, collocation };

/// "invert" | "fbf" | "lpfbf" | "rfbf" | "collocation"; throws amctl::Error naming --method
/// otherwise.
Method parse_method(const std::string& name);
const char* method_name(Method m);

struct CompensationOptions {
  Method method = Method::invert;
  /// The model the method uses (X, Y).
  dynamics::AxisModel model_x = dynamics::AxisModel::rigid();
  dynamics::AxisModel model_y = dynamics::AxisModel::rigid();
  /// The plant the result is simulated on (X, Y); usually equal to the model.
  dynamics::AxisModel plant_x = dynamics::AxisModel::rigid();
  dynamics::AxisModel plant_y = dynamics::AxisModel::rigid();
  double sample_rate_hz = 1000.0;  ///< command step 1 / rate [Hz]
  /// Command time before the first move's start [s]; < 0: automatic (invert: 0; fbf: the
  /// model's settling, 4 / (z w) of the slowest mode, rounded up to whole knots).
  double lead_in_s = -1.0;
  /// Command time after the last move's end [s]; < 0: automatic (5 time constants of the
  /// slowest mode of model and plant, clamped to [0.05, 1] s).
  double tail_s = -1.0;
  /// FBF: knot spacing [s] (< 0: automatic, a quarter of the fastest mode's period) and the
  /// B-spline degree.
  double knot_spacing_s = -1.0;
  int degree = 3;
  /// LPFBF: window length W and overlap O [s] (< 0: automatic, W = max(0.25, 4 settling), O = W/2).
  /// Collocation: the windows are W = max(1 s, 10 settling), O = max(0.25 s, 3 settling).
  double window_s = -1.0;
  double overlap_s = -1.0;
  /// Bound on the command's acceleration |(x_b'', y_b'')| [mm/s^2]; +inf: none. Collocation
  /// enforces it; the other methods report status "base_accel_limit_exceeded" when their
  /// command breaks it.
  double max_base_accel_mm_s2 = std::numeric_limits<double>::infinity();
  /// compensate_file / compensate_file_streaming: judge the command's peak acceleration
  /// against the machine's own limit (Klipper printer.max_accel; Marlin and RepRapFirmware the
  /// smaller of marlin.max_accel X and Y, M201) when no max_base_accel_mm_s2 is given: status
  /// "machine_accel_limit_exceeded" instead of "ok" for a command the firmware would not follow.
  bool judge_machine_accel = true;
  /// Collocation: the effort term of the objective, mean (rho x_b'')^2 next to the mean
  /// squared tracking error, rho in s^2 (1e-9: 1e4 mm/s^2 weighs as 0.01 um of error).
  double effort_weight_s2 = 1e-9;
  int max_solver_iterations = 500;  ///< collocation: IPOPT's iteration limit per window
  /// Also sample the plan's Z and E at the command's samples (for write_gcode).
  bool sample_z_e = false;
  /// The methods other than LPFBF hold the whole command in memory (docs/compensation.md,
  /// "Memory"): told, before anything is allocated for it, how much that will be. A command
  /// beyond max_memory_bytes (0: what /proc/meminfo says is available) is an amctl::Error
  /// saying how much it would take.
  std::function<void(const struct MemoryEstimate&)> on_memory_estimate;
  std::uint64_t max_memory_bytes = 0;
};

/// What compensate() will hold for the command before it computes it.
struct MemoryEstimate {
  std::string method;
  std::uint64_t samples = 0;  ///< command samples (lead-in and tail included)
  std::uint64_t bytes = 0;    ///< samples * kCompensationBytesPerSample, plus the plan
};

/// Memory per command sample of the in-memory methods: the command, the desired path, the
/// simulated nozzle and their Z/E and acceleration columns, the check simulation's copies
/// (measured: docs/compensation.md, "Memory").
inline constexpr std::uint64_t kCompensationBytesPerSample = 240;
/// Longest lead-in or tail a command may be given [s].
inline constexpr double kMaxLeadTail_s = 600.0;

/// How a compensation ended. Its name (to_string) is the JSON's "status".
enum class CompensationStatus {
  ok,                              ///< a command within every limit asked for
  unbounded_command_acceleration,  ///< the plan's jerk is infinite: the inverse's command accel is
  base_accel_limit_exceeded,       ///< the command's acceleration passes max_base_accel_mm_s2
  machine_accel_limit_exceeded,    ///< ... or the machine's own limit (no bound given)
  non_finite_command,              ///< a command sample is NaN or infinite
  infeasible,                      ///< collocation: no command meets the bounds
  solver_failed,                   ///< collocation: the NLP solver stopped without a solution
};

/// "ok", "unbounded_command_acceleration", ... (the enumerator's name).
[[nodiscard]] std::string_view to_string(CompensationStatus s);

struct CompensationResult {
  std::string method;
  CompensationStatus status = CompensationStatus::ok;
  std::string message;  ///< what the status means and what to do
  double motion_time_s = 0.0;
  double compute_time_s = 0.0;       ///< the method and its check simulation
  double real_time_factor = 0.0;     ///< motion_time_s / compute_time_s
  double max_tracking_error_mm = 0.0;  ///< max |simulated nozzle - planned path| at the samples
  double rms_tracking_error_mm = 0.0;
  double max_contour_error_mm = 0.0;   ///< max distance of the simulated nozzle to the path
  double uncompensated_max_tracking_error_mm = 0.0;  ///< the plan itself as the command
  double uncompensated_max_contour_error_mm = 0.0;
  /// Peak |(x_b'', y_b'')| of the exact command; +inf (JSON null) when unbounded.
  double peak_command_accel_mm_s2 = 0.0;
  double lead_in_s = 0.0;
  double tail_s = 0.0;
  double sample_rate_hz = 0.0;
  // FBF only
  double knot_spacing_s = 0.0;
  int degree = 0;
  std::size_t basis_functions = 0;
  // LPFBF only
  double window_s = 0.0, overlap_s = 0.0;
  std::size_t windows = 0;           ///< windows solved (per axis)
  std::size_t max_held_samples = 0;  ///< most desired samples held at once by one axis
  std::size_t max_held_moves = 0;    ///< streaming: most plan moves held at once
  std::size_t samples = 0;           ///< streaming: samples written (the arrays stay empty)
  // Collocation only
  std::string solver_status;         ///< IPOPT's return status (of the first window that failed)
  std::size_t solver_iterations = 0; ///< over all windows
  double max_defect_mm = 0.0;        ///< largest Hermite-Simpson defect of the solution
  double effort_weight_s2 = 0.0;     ///< the effort weight used
  double max_base_accel_mm_s2 = std::numeric_limits<double>::infinity();  ///< the bound given
  /// The machine's acceleration limit the command was judged against (+inf: not judged) and
  /// the key it comes from ("printer.max_accel", "marlin.max_accel").
  double machine_accel_limit_mm_s2 = std::numeric_limits<double>::infinity();
  std::string machine_accel_limit_key;
  // The command and its check, one entry per sample time.
  std::vector<double> t_s, x_cmd_mm, y_cmd_mm, x_des_mm, y_des_mm, x_sim_mm, y_sim_mm;
  /// Collocation: the command's acceleration at the samples, linear between them (the command
  /// is a cubic between samples); the check then simulates that command exactly, and the CSV
  /// has the columns x_cmd_accel_mm_s2,y_cmd_accel_mm_s2. Empty for the other methods.
  std::vector<double> x_cmd_accel_mm_s2, y_cmd_accel_mm_s2;
  /// With CompensationOptions::sample_z_e: the plan's Z and E at the samples (every move of
  /// the plan, retractions included), for write_gcode.
  std::vector<double> z_des_mm, e_des_mm;
};

/// Compensates a time-ordered plan (XY). Throws amctl::Error for bad options (naming them).
CompensationResult compensate(std::span<const plan::PlannedMove> moves,
                              const CompensationOptions& options);

/// Plans `path` for `machine` and compensates the whole plan.
CompensationResult compensate_file(const plan::GcodeInput& input, const machine::Machine& machine,
                                   const CompensationOptions& options);

/// LPFBF over the plan stream of `path` in bounded memory: the command and its check written
/// progressively to `csv_path` (the command table, command_table.hpp: CSV, or .npy by the
/// name) through amctl::OutputFile (a regular file appears at the end, whole or not at all;
/// the CommandTable form leaves commit() to the caller). The result's sample arrays stay empty (see `samples`); the
/// check simulates the plant exactly for the command linear between samples, and the
/// uncompensated error is that of the plan sampled on the same grid.
CompensationResult compensate_file_streaming(const std::string& path, const machine::Machine& machine,
                                             const CompensationOptions& options,
                                             const std::string& csv_path);
CompensationResult compensate_file_streaming(const plan::GcodeInput& input, const machine::Machine& machine,
                                             const CompensationOptions& options, CommandTable& csv);

/// Simulates a sampled XY command (uniform step, linear between samples: constant-velocity
/// moves through dynamics::Simulator) on the plant and returns the nozzle at the sample times.
void simulate_command(const std::vector<double>& t_s, const std::vector<double>& x_cmd_mm,
                      const std::vector<double>& y_cmd_mm, const dynamics::AxisModel& plant_x,
                      const dynamics::AxisModel& plant_y, double sample_rate_hz,
                      std::vector<double>& x_sim_mm, std::vector<double>& y_sim_mm);

/// The nozzle at the sample times for a command whose acceleration is linear between samples
/// (positions and accelerations given at the samples, at rest before the first): the plant's
/// modal states under first-order hold of x_b'' (exact), added to the command.
void simulate_command_foh(const std::vector<double>& x_cmd_mm, const std::vector<double>& y_cmd_mm,
                          const std::vector<double>& x_acc_mm_s2, const std::vector<double>& y_acc_mm_s2,
                          const dynamics::AxisModel& plant_x, const dynamics::AxisModel& plant_y,
                          double sample_rate_hz, std::vector<double>& x_sim_mm, std::vector<double>& y_sim_mm);

/// The summary as JSON (no sample arrays). Non-finite numbers are null.
Json to_json(const CompensationResult& r);

/// The command table (command_table.hpp: time_s, x_cmd_mm, y_cmd_mm, x_des_mm, y_des_mm,
/// x_sim_mm, y_sim_mm, and the command's accelerations when the method has them) as CSV, or as
/// .npy for a path ending in ".npy", through amctl::OutputFile (a regular file whole or not at
/// all). write_table leaves commit() to the caller.
void write_csv(const CompensationResult& r, const std::string& path);
void write_table(const CompensationResult& r, CommandTable& out);

/// The command as dense G-code for firmware without shaping (docs/compensation.md, "Dense
/// G-code"): one G1 per sample step (X, Y from the command, Z and E from the plan, relative E,
/// F the segment's speed), rests as G4, an M204 at the command's peak acceleration, and a
/// header saying what the firmware must allow. Needs r.z_des_mm / r.e_des_mm
/// (CompensationOptions::sample_z_e); throws amctl::Error naming --gcode otherwise, or when
/// the command is unbounded. Written through amctl::OutputFile (commit() left to the caller in
/// the OutputFile form).
void write_gcode(const CompensationResult& r, const std::string& path);
void write_gcode(const CompensationResult& r, OutputFile& out);

}  // namespace amctl::compensation
