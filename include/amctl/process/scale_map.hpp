#pragma once
// Compensation maps: how a shrinkage fit turns into coordinates to print.
#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::process {

/// A continuous, strictly increasing piecewise-linear map of one coordinate about an origin:
/// factors[0] applies for u <= breaks[0], factors[i] for breaks[i-1] < u <= breaks[i], the
/// last factor above the last break (u = coordinate - origin, in mm; negative u uses
/// factors[0]). Continuity keeps every layer (all moves at one Z) at one new Z and keeps the
/// order of layers: the map is g(u) = g(b_i) + C_{i+1} (u - b_i) between breaks.
class AxisMap {
 public:
  AxisMap() = default;
  /// Throws amctl::Error unless factors.size() == breaks.size() + 1, factors are finite and
  /// > 0, and breaks are finite, > 0 and strictly increasing.
  AxisMap(std::vector<double> factors, std::vector<double> breaks_mm);
  static AxisMap uniform(double factor) { return AxisMap({factor}, {}); }

  /// g(u) for u = coordinate - origin.
  [[nodiscard]] double map(double u_mm) const;
  /// g^-1(v).
  [[nodiscard]] double inverse(double v_mm) const;
  /// dg/du at u (the factor of the range holding u; the lower one at a break).
  [[nodiscard]] double slope_at(double u_mm) const;
  /// The factor of the range that holds a dimension of size h (h <= break -> lower range).
  [[nodiscard]] double factor_for_size(double h_mm) const { return slope_at(h_mm); }
  [[nodiscard]] bool is_identity() const;
  [[nodiscard]] bool is_uniform() const { return breaks_.empty(); }
  [[nodiscard]] const std::vector<double>& factors() const { return factors_; }
  [[nodiscard]] const std::vector<double>& breaks_mm() const { return breaks_; }

 private:
  std::vector<double> factors_{1.0};
  std::vector<double> breaks_;
  std::vector<double> knots_;  // g(breaks_[i])
};

/// The scale factors a shrinkage compensation may use (AxisMap refuses others).
inline constexpr double kMinScaleFactor = 0.5;
inline constexpr double kMaxScaleFactor = 2.0;

/// X, Y, Z maps and the origin they scale about.
struct ScaleMap {
  std::array<AxisMap, 3> axes{};
  std::array<double, 3> origin_mm{0.0, 0.0, 0.0};

  [[nodiscard]] std::array<double, 3> apply(const std::array<double, 3>& p) const {
    return {origin_mm[0] + axes[0].map(p[0] - origin_mm[0]),
            origin_mm[1] + axes[1].map(p[1] - origin_mm[1]),
            origin_mm[2] + axes[2].map(p[2] - origin_mm[2])};
  }
};

/// Parses "x=1.00827,y=1.00847,z=0.9902:10:1.0032" (factor:break:factor:... per axis; axes
/// not named keep factor 1; "xy=F" sets both X and Y; "all=F" every axis).
[[nodiscard]] std::array<AxisMap, 3> parse_factor_spec(std::string_view spec);

}  // namespace amctl::process
