#include "amctl/dynamics/model.hpp"

#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"

namespace amctl::dynamics {

namespace {
constexpr double kTwoPi = 2.0 * std::numbers::pi;

void check_mode(const Mode& m, std::size_t i) {
  const std::string where = fmt::format("mode {}", i);
  if (!std::isfinite(m.natural_frequency_hz) || m.natural_frequency_hz <= 0.0) {
    throw Error(fmt::format("{}: natural_frequency_hz must be a finite number > 0, got {}",
                            where, m.natural_frequency_hz));
  }
  if (!std::isfinite(m.damping_ratio) || m.damping_ratio < 0.0) {
    throw Error(fmt::format("{}: damping_ratio must be a finite number >= 0, got {}", where,
                            m.damping_ratio));
  }
  if (!std::isfinite(m.participation)) {
    throw Error(fmt::format("{}: participation must be finite, got {}", where, m.participation));
  }
}
}  // namespace

AxisModel AxisModel::rigid() { return AxisModel{}; }

AxisModel AxisModel::from_modes(std::vector<Mode> modes) {
  for (std::size_t i = 0; i < modes.size(); ++i) check_mode(modes[i], i);
  AxisModel m;
  m.modes_ = std::move(modes);
  return m;
}

AxisModel AxisModel::belt(double natural_frequency_hz, double damping_ratio) {
  if (!std::isfinite(natural_frequency_hz) || natural_frequency_hz <= 0.0) {
    throw Error(fmt::format("natural_frequency_hz must be a finite number > 0, got {}",
                            natural_frequency_hz));
  }
  if (!std::isfinite(damping_ratio) || damping_ratio < 0.0) {
    throw Error(fmt::format("damping_ratio must be a finite number >= 0, got {}", damping_ratio));
  }
  return from_modes({Mode{natural_frequency_hz, damping_ratio, 1.0}});
}

AxisModel AxisModel::belt_rad_s(double w, double damping_ratio) {
  if (!std::isfinite(w) || w <= 0.0) {
    throw Error(fmt::format("natural_frequency_rad_s must be a finite number > 0, got {}", w));
  }
  return belt(w / kTwoPi, damping_ratio);
}

AxisModel AxisModel::belt(const BeltParameters& p) {
  require_positive("mass_kg", p.mass_kg);
  require_positive("stiffness_n_per_m", p.stiffness_n_per_m);
  require_non_negative("damping_n_s_per_m", p.damping_n_s_per_m);
  const double w = std::sqrt(p.stiffness_n_per_m / p.mass_kg);          // k/m = w^2
  const double z = p.damping_n_s_per_m / (2.0 * std::sqrt(p.stiffness_n_per_m * p.mass_kg));
  return belt(w / kTwoPi, z);                                           // c/m = 2 z w
}

double AxisModel::max_natural_frequency_hz() const {
  double f = 0.0;
  for (const Mode& m : modes_) f = std::max(f, m.natural_frequency_hz);
  return f;
}

Eigen::MatrixXd AxisModel::A() const {
  const int n = order();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t i = 0; i < modes_.size(); ++i) {
    const double w = kTwoPi * modes_[i].natural_frequency_hz, z = modes_[i].damping_ratio;
    const int k = 2 * static_cast<int>(i);
    a(k, k + 1) = w;
    a(k + 1, k) = -w;
    a(k + 1, k + 1) = -2.0 * z * w;
  }
  return a;
}

Eigen::VectorXd AxisModel::B() const {
  Eigen::VectorXd b = Eigen::VectorXd::Zero(order());
  for (std::size_t i = 0; i < modes_.size(); ++i) {
    const double w = kTwoPi * modes_[i].natural_frequency_hz;
    b(2 * static_cast<int>(i) + 1) = -modes_[i].participation / w;
  }
  return b;
}

Eigen::RowVectorXd AxisModel::C() const {
  Eigen::RowVectorXd c = Eigen::RowVectorXd::Zero(order());
  for (std::size_t i = 0; i < modes_.size(); ++i) c(2 * static_cast<int>(i)) = 1.0;
  return c;
}

control::StateSpace seed000_axis_state_space(double w, double z) {
  require_positive("natural_frequency_rad_s", w);
  require_non_negative("damping_ratio", z);
  // x'' = -(c/m) x' - (k/m) x + (c/m) x_b' + (k/m) x_b   (3.11), k/m = w^2, c/m = 2 z w
  return control::StateSpace(Eigen::MatrixXd{{0.0, 1.0}, {-w * w, -2.0 * z * w}},
                             Eigen::MatrixXd{{0.0, 0.0}, {w * w, 2.0 * z * w}},
                             Eigen::MatrixXd{{1.0, 0.0}}, Eigen::MatrixXd::Zero(1, 2));
}

control::StateSpace seed000_xy_state_space(double wx, double zx, double wy, double zy) {
  const control::StateSpace x = seed000_axis_state_space(wx, zx);
  const control::StateSpace y = seed000_axis_state_space(wy, zy);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(4, 4), b = Eigen::MatrixXd::Zero(4, 4);
  Eigen::MatrixXd c = Eigen::MatrixXd::Zero(2, 4);
  a.block(0, 0, 2, 2) = x.A();
  a.block(2, 2, 2, 2) = y.A();
  b.block(0, 0, 2, 2) = x.B();
  b.block(2, 2, 2, 2) = y.B();
  c(0, 0) = 1.0;
  c(1, 2) = 1.0;
  return control::StateSpace(std::move(a), std::move(b), std::move(c),
                             Eigen::MatrixXd::Zero(2, 4));
}

void require_above_nyquist(double sample_rate_hz, const std::vector<const AxisModel*>& models) {
  // A rate the simulation can run at: 1e12 Hz would take hours per second of print.
  require_in_range("sample_rate_hz", kSampleRateRange, sample_rate_hz);
  double f = 0.0;
  for (const AxisModel* m : models) f = std::max(f, m->max_natural_frequency_hz());
  if (sample_rate_hz <= 2.0 * f) {
    throw Error(fmt::format(
        "sample_rate_hz {} is at or below the Nyquist limit of the model: it must exceed twice "
        "the highest natural frequency, 2 x {} Hz = {} Hz",
        sample_rate_hz, f, 2.0 * f));
  }
}

}  // namespace amctl::dynamics
