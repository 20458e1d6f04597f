#pragma once
// Winch (cable robot; klippy/kinematics/winch.py, chelper/kin_winch.c; read at 84104bbb,
// nothing copied): 3 or 4 cables (stepper_a .. stepper_d), each motor's position the cable
// length |tool - anchor|. Klipper checks no limit on it.
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <span>
#include <string_view>
#include <vector>

#include "amctl/kinematics/keys.hpp"
#include "amctl/kinematics/kinematics.hpp"
#include "amctl/kinematics/klipper_config.hpp"

namespace amctl::kinematics {

/// Where a cable is anchored (Klipper anchor_x, anchor_y, anchor_z; required).
struct WinchAnchor {
  std::optional<double> x_mm, y_mm, z_mm;
  bool operator==(const WinchAnchor&) const = default;
};

struct Winch {
  static constexpr std::string_view kName = "winch";
  std::map<std::string, WinchAnchor> anchors;  ///< by drive-train key a, b, c (, d)
  bool operator==(const Winch&) const = default;

  /// printer.cfg: [stepper_a], [stepper_b], [stepper_c] (required), [stepper_d].
  [[nodiscard]] static std::vector<KlipperStepper> klipper_steppers(const KlipperConfig& cfg);
  /// Each cable's anchor_x, anchor_y, anchor_z (required).
  [[nodiscard]] static Winch from_klipper(const KlipperConfig& cfg);
  [[nodiscard]] static std::span<const std::string_view> printer_options() { return {}; }
  /// TOML: [stepper_a..d] anchor_x, anchor_y, anchor_z.
  [[nodiscard]] static std::span<const ParamKey<Winch>> keys();
  [[nodiscard]] static Unit unit_of(std::string_view) { return Unit::mm; }
  /// Motors beyond the axes' (stepper_x, stepper_z1, ...): The cables stepper_a .. stepper_d.
  [[nodiscard]] bool owns_stepper(std::string_view key) const { return key == "a" || key == "b" || key == "c" || key == "d"; }
};

[[nodiscard]] std::unique_ptr<Kinematics> make_kinematics(const Winch& p, const Context& ctx);

}  // namespace amctl::kinematics
