#pragma once
// Internal to the kinematics module: the kinematics whose motors are fixed linear combinations
// of X, Y, Z on three rails (cartesian, corexy, corexz, hybrid_corexy, hybrid_corexz; Klipper's
// kin_cartesian.c, kin_corexy.c, kin_corexz.c and the hybrid kinematics' callbacks). They
// differ only in their three motor rows and whether a dual carriage is allowed, so each file
// gives its rows and this template the rest.
#include <array>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics::detail {

/// The rows of stepper_x, stepper_y and stepper_z* over (X, Y, Z, E).
struct MotorRows {
  std::array<double, 4> x, y, z;
};

/// A parameter type with a dual carriage (cartesian, the hybrids) can hold an IDEX axis.
template <class P>
concept HasDualCarriage = requires(P p) { p.dual_carriage; };

template <class P>
class RailKinematics : public Kinematics {
 public:
  RailKinematics(const P& p, const Context& ctx, const MotorRows& rows)
      : p_(p), th_(ctx.toolhead), rows_(rows) {
    check_rails(p.rails);
    if constexpr (HasDualCarriage<P>) check_dual_carriage(p.rails, p.dual_carriage);
  }
  std::string_view name() const override { return P::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>& missing) const override {
    return cartesian_motors(keys, rows_.x, rows_.y, rows_.z, missing);
  }
  MoveRules move_rules() const override { return cartesian_move_rules(p_.rails, th_); }
  std::vector<IdexPair> idex_pairs() const override {
    if constexpr (HasDualCarriage<P>) {
      if (p_.dual_carriage && !p_.dual_carriage->axis.empty()) {
        return {idex_pair(p_.rails, *p_.dual_carriage)};
      }
    }
    return {};
  }
  Homing homing() const override {
    Homing h = cartesian_homing(p_.rails);
    // G28 puts the first carriage of an IDEX axis at its endstop.
    for (const IdexPair& d : idex_pairs()) {
      h.position_mm[static_cast<std::size_t>(d.axis)] = d.position_endstop_mm[0];
    }
    return h;
  }
  std::optional<LinearMap> linear_map() const override {
    std::vector<std::string> missing;
    return linear_map_of(motors({"x", "y", "z"}, missing));
  }

 protected:  // the limited kinematics add their speed limits
  P p_;
  Toolhead th_;
  MotorRows rows_;
};

/// P's rails from its stepper sections; its dual carriage, or a refusal where it has none.
template <class P>
P rails_from_klipper(const KlipperConfig& cfg) {
  P k;
  for (const KlipperStepper& s : P::klipper_steppers(cfg)) read_rail(cfg.section(s.section), k.rails, s.key);
  if constexpr (HasDualCarriage<P>) k.dual_carriage = read_dual_carriage(cfg);
  else refuse_dual_carriage(cfg);
  return k;
}

/// P's TOML keys: the rails' and, where it has one, the dual carriage's.
template <class P>
std::span<const ParamKey<P>> rail_keys() {
  static const std::vector<ParamKey<P>> keys = [] {
    std::vector<ParamKey<P>> k;
    add_rail_keys(k);
    if constexpr (HasDualCarriage<P>) add_dual_carriage_keys(k);
    return k;
  }();
  return keys;
}

}  // namespace amctl::kinematics::detail
