// Klipper's `none` kinematics: no motors, no checks.
#include "amctl/kinematics/none.hpp"

#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {
namespace {

class NoneKinematics final : public Kinematics {
 public:
  std::string_view name() const override { return None::kName; }
  std::vector<Motor> motors(const std::vector<std::string>&, std::vector<std::string>&) const override {
    return {};
  }
  // No speed limit but the toolhead's (infinite limits are no-ops).
  MoveRules move_rules() const override { return {}; }
};

}  // namespace

None None::from_klipper(const KlipperConfig& cfg) {
  detail::refuse_dual_carriage(cfg);
  return {};
}

std::unique_ptr<Kinematics> make_kinematics(const None&, const Context&) {
  return std::make_unique<NoneKinematics>();
}

}  // namespace amctl::kinematics
