#pragma once
// The kinematics a machine can have, as one value type: a variant of every kinematics'
// parameters. Adding a kinematics is its header and source (params, make_kinematics) and one
// entry in the list below.
#include <memory>
#include <span>
#include <string_view>
#include <variant>

#include "amctl/kinematics/cartesian.hpp"
#include "amctl/kinematics/corexy.hpp"
#include "amctl/kinematics/corexz.hpp"
#include "amctl/kinematics/delta.hpp"
#include "amctl/kinematics/deltesian.hpp"
#include "amctl/kinematics/generic_cartesian.hpp"
#include "amctl/kinematics/hybrid_corexy.hpp"
#include "amctl/kinematics/hybrid_corexz.hpp"
#include "amctl/kinematics/limited_cartesian.hpp"
#include "amctl/kinematics/limited_corexy.hpp"
#include "amctl/kinematics/limited_corexz.hpp"
#include "amctl/kinematics/none.hpp"
#include "amctl/kinematics/polar.hpp"
#include "amctl/kinematics/rotary_delta.hpp"
#include "amctl/kinematics/winch.hpp"

namespace amctl::kinematics {

/// Every kinematics, in the order amctl lists them.
using Params = std::variant<Cartesian, CoreXY, CoreXZ, HybridCoreXY, HybridCoreXZ, Delta, None,
                            Winch, Deltesian, GenericCartesian, Polar, RotaryDelta,
                            LimitedCartesian, LimitedCoreXY, LimitedCoreXZ>;

/// Klipper's name of the kinematics held.
[[nodiscard]] std::string_view name_of(const Params& p);
/// Every kinematics' name, in Params order.
[[nodiscard]] std::span<const std::string_view> names();
/// Default parameters of the kinematics called `name`; nothing for an unknown name.
[[nodiscard]] std::optional<Params> params_named(std::string_view name);
/// The parameters of kinematics number `index` (of Params) for a machine that had `from`
/// (`--set printer.kinematics=...`): the rails and an IDEX's dual carriage carry over between
/// the cartesian-like kinematics. Throws amctl::Error when `from` has a dual carriage the new
/// kinematics cannot have.
[[nodiscard]] Params convert(const Params& from, std::size_t index);

/// The kinematics built from its parameters (checks them: throws amctl::Error naming the
/// missing or inconsistent key).
[[nodiscard]] std::unique_ptr<Kinematics> make(const Params& p, const Context& ctx);

/// True when the variant holds K.
template <class K>
[[nodiscard]] bool is(const Params& p) {
  return std::holds_alternative<K>(p);
}

}  // namespace amctl::kinematics
