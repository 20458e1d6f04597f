// What every kinematics shares: the default motor-curve search, the default move checks, the
// motor naming helpers and the factory over the Params variant.
#include "amctl/kinematics/kinematics.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/params.hpp"

namespace amctl::kinematics {

std::string_view to_string(Unit u) { return u == Unit::rad ? "rad" : "mm"; }

double MotorCurve::along(const Vec3& p0, const Vec3& u, double s) const {
  return position({p0[0] + u[0] * s, p0[1] + u[1] * s, p0[2] + u[2] * s});
}

double MotorCurve::slope_along(const Vec3& p0, const Vec3& u, double s, double s_end) const {
  const double h = 1e-6;
  const double a = std::max(0.0, s - h), b = std::min(s_end, s + h);
  return b > a ? (along(p0, u, b) - along(p0, u, a)) / (b - a) : 0.0;
}

void MotorCurve::turning_points(const Vec3& p0, const Vec3& u, double s_end,
                                std::vector<double>& out) const {
  const int n = samples_;
  double prev_s = 0.0, prev_d = slope_along(p0, u, 0.0, s_end);
  for (int i = 1; i <= n; ++i) {
    const double si = s_end * i / n;
    const double di = slope_along(p0, u, si, s_end);
    if ((prev_d > 0.0 && di < 0.0) || (prev_d < 0.0 && di > 0.0)) {
      double a = prev_s, b = si;
      while (b - a > 1e-13 * (1.0 + s_end)) {
        const double mid = 0.5 * (a + b);
        if (mid <= a || mid >= b) break;
        ((slope_along(p0, u, mid, s_end) > 0.0) == (prev_d > 0.0) ? a : b) = mid;
      }
      out.push_back(0.5 * (a + b));
    }
    if (di != 0.0) {
      prev_s = si;
      prev_d = di;
    }
  }
}

std::string MotorCurve::out_of_reach(const Vec3& p, std::string_view motor) const {
  return fmt::format("the toolhead at X={:.3f} Y={:.3f} Z={:.3f} is out of reach of {}", p[0],
                     p[1], p[2], motor);
}

std::optional<RangeViolation> Kinematics::check_range(const MoveGeometry&) const {
  return std::nullopt;
}

void Kinematics::limit_move(const MoveGeometry&, double&, double&) const {}

std::string Kinematics::stepper_carriages_error(
    const std::map<std::string, std::string, std::less<>>&, const std::string& stepper,
    const std::string&, bool) const {
  return fmt::format("invalid STEPPER '{}' specified", stepper);
}

std::vector<std::string> axis_motor_keys(const std::vector<std::string>& keys, std::string_view axis) {
  std::vector<std::string> out;
  for (const std::string& k : keys) {
    if (k.size() < axis.size() || k.compare(0, axis.size(), axis) != 0) continue;
    if (!std::all_of(k.begin() + static_cast<std::ptrdiff_t>(axis.size()), k.end(),
                     [](char c) { return c >= '0' && c <= '9'; })) {
      continue;
    }
    out.push_back(k);
  }
  // Numeric suffix order: "z" before "z1" before "z2" ... "z10".
  std::sort(out.begin(), out.end(), [](const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return a.size() < b.size();
    return a < b;
  });
  return out;
}

std::string stepper_name(std::string_view key) { return fmt::format("stepper_{}", key); }

// ---- the variant ----

namespace {

template <std::size_t... I>
constexpr std::array<std::string_view, sizeof...(I)> names_of(std::index_sequence<I...>) {
  return {std::variant_alternative_t<I, Params>::kName...};
}
constexpr auto kNames = names_of(std::make_index_sequence<std::variant_size_v<Params>>());

template <std::size_t... I>
std::optional<Params> default_named(std::string_view name, std::index_sequence<I...>) {
  std::optional<Params> out;
  ((kNames[I] == name ? (out.emplace(std::in_place_index<I>), true) : false) || ...);
  return out;
}

}  // namespace

std::string_view name_of(const Params& p) { return kNames[p.index()]; }
std::span<const std::string_view> names() { return kNames; }

std::optional<Params> params_named(std::string_view name) {
  return default_named(name, std::make_index_sequence<std::variant_size_v<Params>>());
}

Params convert(const Params& from, std::size_t index) {
  if (from.index() == index) return from;
  Params to = *params_named(kNames.at(index));
  std::visit(
      [&](auto& t) {
        std::visit(
            [&](const auto& f) {
              if constexpr (requires { t.rails; f.rails; }) t.rails = f.rails;
              if constexpr (requires { f.dual_carriage; }) {
                if (f.dual_carriage) {
                  if constexpr (requires { t.dual_carriage; }) {
                    t.dual_carriage = f.dual_carriage;
                  } else {
                    throw Error("dual_carriage: Klipper supports a dual carriage on cartesian, "
                                "hybrid_corexy and hybrid_corexz kinematics only");
                  }
                }
              }
            },
            from);
      },
      to);
  return to;
}

std::unique_ptr<Kinematics> make(const Params& p, const Context& ctx) {
  return std::visit([&](const auto& k) { return make_kinematics(k, ctx); }, p);
}

}  // namespace amctl::kinematics
