#pragma once
// Linear models of one printer axis.
//
// Seed 000 (3.11): the nozzle carriage x (mass m) is pulled through a belt, a spring k and a
// damper c in parallel, by the ideal motor/pulley position x_b:
//     m x'' + c (x' - x_b') + k (x - x_b) = 0.
// With the tracking error e = x - x_b this is  e'' + 2 z w e' + w^2 e = -x_b''  (w^2 = k/m,
// 2 z w = c/m): the error is driven only by the commanded acceleration. Several modes are
// superposed in the same way (modal model):
//     e_i'' + 2 z_i w_i e_i' + w_i^2 e_i = -g_i x_b'',   x = x_b + sum_i e_i,
// g_i the participation of mode i (one belt mode: g = 1, exactly 3.11).
// State (scaled so that ||A|| ~ w): [e_1, e_1'/w_1, e_2, e_2'/w_2, ...]; input u = x_b''.
//     A_i = [[0, w], [-w, -2 z w]],  B_i = [0, -g / w],  C_i = [1, 0].
// Models are immutable values; simulation state lives with the caller.
#include <vector>

#include <Eigen/Dense>

#include "amctl/control/state_space.hpp"

namespace amctl::dynamics {

/// One vibration mode of an axis.
struct Mode {
  double natural_frequency_hz = 0.0;  ///< undamped natural frequency f = w / (2 pi) [Hz]
  double damping_ratio = 0.0;         ///< z >= 0 (0 = undamped)
  double participation = 1.0;         ///< g: share of the commanded acceleration driving it
};

/// Physical belt parameters of seed 000 (3.11). Any consistent unit set works since only
/// k/m [1/s^2] and c/m [1/s] enter.
struct BeltParameters {
  double mass_kg = 0.0;               ///< moving mass m > 0
  double stiffness_n_per_m = 0.0;     ///< belt stiffness k > 0
  double damping_n_s_per_m = 0.0;     ///< belt damping c >= 0
};

class AxisModel {
 public:
  /// No dynamics: the nozzle is exactly where the motors put it.
  static AxisModel rigid();
  /// Seed 000 belt model from natural frequency [Hz] and damping ratio.
  static AxisModel belt(double natural_frequency_hz, double damping_ratio);
  /// Seed 000 belt model from angular natural frequency [rad/s] (the thesis's w).
  static AxisModel belt_rad_s(double natural_frequency_rad_s, double damping_ratio);
  /// Seed 000 belt model from mass, stiffness and damping.
  static AxisModel belt(const BeltParameters& p);
  /// Modal superposition of several modes. Throws amctl::Error naming the field for
  /// frequency <= 0, damping ratio < 0, or a non-finite participation.
  static AxisModel from_modes(std::vector<Mode> modes);

  [[nodiscard]] const std::vector<Mode>& modes() const { return modes_; }
  [[nodiscard]] int order() const { return 2 * static_cast<int>(modes_.size()); }
  [[nodiscard]] bool is_rigid() const { return modes_.empty(); }
  [[nodiscard]] double max_natural_frequency_hz() const;
  /// Continuous-time matrices in the scaled modal coordinates above (input u = x_b'').
  [[nodiscard]] Eigen::MatrixXd A() const;
  [[nodiscard]] Eigen::VectorXd B() const;
  [[nodiscard]] Eigen::RowVectorXd C() const;

 private:
  std::vector<Mode> modes_;
};

/// Seed 000 (3.12), one axis, physical coordinates: state [x, x'], input [x_b, x_b'],
/// output x. (The printed 3.12 uses k_x/m_x for both axes; each axis has its own.)
[[nodiscard]] control::StateSpace seed000_axis_state_space(double natural_frequency_rad_s,
                                                           double damping_ratio);
/// Seed 000 (3.12) for X and Y together, state [x, x', y, y'], input [x_b, x_b', y_b, y_b'],
/// outputs [x, y], each axis with its own parameters.
[[nodiscard]] control::StateSpace seed000_xy_state_space(double wx_rad_s, double zx,
                                                         double wy_rad_s, double zy);

/// Throws amctl::Error naming "sample_rate_hz" unless sample_rate_hz exceeds twice the
/// highest natural frequency of every model (the Nyquist limit of the sampled output).
void require_above_nyquist(double sample_rate_hz, const std::vector<const AxisModel*>& models);

}  // namespace amctl::dynamics
