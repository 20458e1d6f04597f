#pragma once
// A shaper recommendation from an identified modal model with the shaped simulation
// (docs/resonance.md, "Recommendation from the model").
//
// The model (natural frequency, damping ratio) drives both X and Y (dynamics::AxisModel::belt).
// A ringing-tower-like path is planned once on the machine: square perimeters with sharp
// corners, printed at a few speeds and accelerations. Each candidate (shaper type, frequency)
// shapes both axes (simulation::ShapedStreamingSimulation) and is scored by the largest contour
// error of the shaped nozzle against the planned path on the extruding moves (the smoothing of
// the shaper counts as error). A candidate is admissible when Klipper's smoothing measure at the
// machine's accel and scv 5 mm/s is within the budget (default 0.12 mm, Klipper's target).
// For each type: a coarse geometric grid of frequencies over the admissible range, then a
// golden-section refinement on the bracket around the best grid point.
#include <optional>
#include <string>
#include <vector>

#include "amctl/core/json.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"
#include "amctl/resonance/calibrate.hpp"

namespace amctl::tuning {

struct ModalModel {
  double natural_frequency_hz = 0.0;
  double damping_ratio = 0.0;
};

struct RecommendOptions {
  std::vector<std::string> shapers{"zv", "mzv", "ei", "2hump_ei", "3hump_ei"};
  double shaper_damping_ratio = 0.1;  ///< the shapers' design damping ratio (Klipper's default)
  double max_smoothing_mm = 0.12;     ///< Klipper's target smoothing
  double scv_mm_s = 5.0;              ///< for the smoothing measure (Klipper's calibration)
  /// Accel for the smoothing measure; nullopt: the machine's (Klipper max_accel, Marlin print accel).
  std::optional<double> smoothing_accel_mm_s2;
  std::size_t grid_points = 12;       ///< coarse grid per type
  std::size_t golden_iterations = 12; ///< refinement steps per type
  double sample_rate_hz = 2000.0;     ///< simulation rate
};

/// One simulated candidate.
struct Candidate {
  std::string name;             ///< shaper type ("" = unshaped)
  double freq_hz = 0.0;
  double contour_error_mm = 0.0;  ///< max over the extruding moves
  double rms_contour_error_mm = 0.0;
  double smoothing_mm = 0.0;      ///< Klipper's measure at the budget's accel and scv
};

struct Recommendation {
  ModalModel model;
  Candidate best;                  ///< the recommendation
  std::vector<Candidate> per_type; ///< the best admissible candidate of each type
  Candidate unshaped;
  std::optional<Candidate> klipper;  ///< Klipper's pick simulated the same way
  double max_smoothing_mm = 0.0;
  double smoothing_accel_mm_s2 = 0.0;
  double scv_mm_s = 0.0;
  std::vector<Candidate> evaluated; ///< every shaped simulation of the search, in the order run
  std::size_t evaluations = 0;     ///< shaped simulations of the search (Klipper's pick not counted)
  std::vector<std::string> skipped; ///< types the budget pushes above 10 f_n (not searched)
  double sample_rate_hz = 0.0;     ///< of the simulations: max(options', 30 f_n, 8 x highest candidate)
  std::size_t path_moves = 0;
  double path_time_s = 0.0;
  double compute_time_s = 0.0;
};

/// The ringing-tower-like test path as G-code (squares of 40 mm at 60, 120 and 200 mm/s, each
/// at half and at the full machine accel, 2 loops each, 0.2 mm layers).
[[nodiscard]] std::string ringing_tower_gcode(const machine::Machine& machine);

/// The smallest frequency at which `type` meets the smoothing budget (bisection, 1e-4 Hz).
[[nodiscard]] double min_frequency_for_smoothing(const std::string& type, double damping_ratio,
                                                 double accel_mm_s2, double scv_mm_s,
                                                 double max_smoothing_mm);

/// The recommendation. `klipper_pick` (name, freq) is simulated beside it when given. Throws
/// amctl::Error naming the parameter for a model frequency <= 0 or not finite, a damping ratio
/// outside [0, 1), a smoothing budget <= 0, an unknown shaper type.
[[nodiscard]] Recommendation recommend(const ModalModel& model, const machine::Machine& machine,
                                       const RecommendOptions& options = {},
                                       const std::optional<resonance::ShaperFit>& klipper_pick = std::nullopt);

/// Klipper's pick for the model alone: klipper_calibrate on the PSD that TEST_RESONANCES would
/// record from it (base-excited mode, |H(f)|^2 times (accel_per_hz f)^2, 0.25 Hz bins to 200 Hz),
/// with Klipper's --max_smoothing when given.
[[nodiscard]] resonance::ShaperFit klipper_pick_for_model(const ModalModel& model,
                                                          std::optional<double> max_smoothing_mm = std::nullopt);

/// `model_recommendation{name, freq_hz, contour_error_mm, smoothing_mm}`, `unshaped`,
/// `klipper_pick` (same keys, or null), `per_type[]`, `model`, `budget`, `search`.
[[nodiscard]] Json to_json(const Recommendation& r);
[[nodiscard]] std::string to_text(const Recommendation& r);

}  // namespace amctl::tuning
