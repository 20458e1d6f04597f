// generic_cartesian: carriages and the steppers' carriage expressions read and checked as
// generic_cartesian.py and kinematic_stepper.py do, each stepper a linear row (kin_generic.c),
// the primary carriages' ranges and endstops, the IDEX pairs of idex_modes.py.
#include "amctl/kinematics/generic_cartesian.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/kinematics/rails.hpp"

namespace amctl::kinematics {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

using Term = std::pair<std::string, double>;

/// The axis a carriage moves: its own (a primary, a dual carriage that names one) or its
/// primary's (extra carriages, dual carriages without an axis of their own).
const std::string& axis_of(const GenericCartesian& m, const std::string& name) {
  static const std::string kNone;
  auto it = m.carriages.find(name);
  for (int depth = 0; it != m.carriages.end() && it->second.axis.empty() &&
                      !it->second.primary_carriage.empty() && depth < 4;
       ++depth) {
    it = m.carriages.find(it->second.primary_carriage);
  }
  return it == m.carriages.end() ? kNone : it->second.axis;
}

/// The terms of a `carriages` expression (kinematic_stepper.py parse_carriages_string: the
/// text is cut before every + or - after the first character; a term is NAME, +NAME, -NAME or
/// COEFF*NAME with COEFF a number that carries its sign).
std::vector<Term> carriage_terms(std::string_view expr, const GenericCartesian& m, std::string_view label) {
  std::vector<Term> terms;
  std::array<bool, 3> seen{};
  std::size_t next = 0;
  while (next < expr.size()) {
    const std::size_t cut = expr.find_first_of("+-", next + 1);
    const std::size_t end = cut == std::string_view::npos ? expr.size() : cut;
    std::string_view term = trim(expr.substr(next, end - next));
    next = end;
    double coeff = 1.0;
    std::string_view name = term;
    const std::size_t star = term.find('*');
    if (star != std::string_view::npos) {
      if (term.find('*', star + 1) != std::string_view::npos) {
        throw Error(fmt::format("{}: invalid term '{}' in '{}', expected NAME or COEFF*NAME",
                                label, term, expr));
      }
      const std::string number(trim(term.substr(0, star)));
      char* stop = nullptr;
      coeff = std::strtod(number.c_str(), &stop);
      if (number.empty() || stop != number.c_str() + number.size() || !std::isfinite(coeff)) {
        throw Error(fmt::format("{}: invalid coefficient '{}' in '{}', expected a number",
                                label, number, expr));
      }
      name = term.substr(star + 1);
    } else if (!term.empty() && (term.front() == '-' || term.front() == '+')) {
      coeff = term.front() == '-' ? -1.0 : 1.0;
      name = term.substr(1);
    }
    const auto it = m.carriages.find(std::string(name));
    if (it == m.carriages.end()) {
      std::vector<std::string> known;
      for (const auto& [k, c] : m.carriages) known.push_back(k);
      throw Error(fmt::format("{}: unknown carriage '{}' in '{}', expected one of {}", label, name,
                              expr, fmt::join(known, ", ")));
    }
    const std::string& axis_name = axis_of(m, it->first);
    if (axis_name != "x" && axis_name != "y" && axis_name != "z") {
      throw Error(fmt::format("{}: carriage '{}' has no axis x, y or z (through its "
                              "primary_carriage), expected one",
                              label, name));
    }
    const auto axis = static_cast<std::size_t>(axis_name[0] - 'x');
    if (seen[axis]) {
      throw Error(fmt::format("{}: axis '{}' is referenced by more than one carriage in '{}', "
                              "expected each axis at most once",
                              label, axis_name, expr));
    }
    seen[axis] = true;
    terms.emplace_back(std::string(name), coeff);
  }
  return terms;
}

/// Carriage `name` moves with the toolhead: a primary carriage unless its axis has a dual
/// carriage and that one is active; a dual carriage when duals are active; an extra carriage
/// as its primary.
bool carriage_active(const GenericCartesian& m, const std::string& name, bool dual_active, int depth = 0) {
  const auto it = m.carriages.find(name);
  if (it == m.carriages.end() || depth > 4) return false;  // refused by the checks already
  const Carriage& c = it->second;
  switch (c.type) {
    // A dual carriage without a primary (a second IDEX pair on one axis) stays parked.
    case Carriage::Type::dual: return dual_active && !c.primary_carriage.empty();
    case Carriage::Type::extra:
      return carriage_active(m, c.primary_carriage, dual_active, depth + 1);
    case Carriage::Type::primary:
      if (!dual_active) return true;
      for (const auto& [k, other] : m.carriages) {
        if (other.type == Carriage::Type::dual && other.primary_carriage == name) return false;
      }
      return true;
  }
  return true;
}

std::array<double, 3> row_of(const std::vector<Term>& terms, const GenericCartesian& m, bool dual_active) {
  std::array<double, 3> row{};
  for (const auto& [name, coeff] : terms) {
    if (!carriage_active(m, name, dual_active)) continue;
    const std::string& axis = axis_of(m, name);
    if (axis.empty()) continue;  // refused by carriage_terms already
    row[static_cast<std::size_t>(axis[0] - 'x')] += coeff;
  }
  return row;
}

}  // namespace

std::array<double, 3> parse_carriages(std::string_view expr, const GenericCartesian& m,
                                      std::string_view label, bool with_dual) {
  return row_of(carriage_terms(expr, m, label), m, with_dual);
}

GenericCartesianGeometry generic_cartesian_geometry(const GenericCartesian& m) {
  GenericCartesianGeometry g;
  // Carriages: one primary per axis; extra and dual carriages name an existing primary.
  std::array<std::string, 3> primary;
  for (const auto& [name, c] : m.carriages) {
    if (c.type == Carriage::Type::primary) {
      if (c.axis != "x" && c.axis != "y" && c.axis != "z") {
        throw Error(fmt::format("carriage {}: axis must be x, y or z, got '{}'", name, c.axis));
      }
      const auto a = static_cast<std::size_t>(c.axis[0] - 'x');
      if (!primary[a].empty()) {
        throw Error(fmt::format("axis '{}' is set for more than one primary carriage ({}, {}), "
                                "expected one carriage per axis",
                                c.axis, primary[a], name));
      }
      primary[a] = name;
    } else if (c.type == Carriage::Type::dual && c.primary_carriage.empty()) {
      // generic_cartesian.py: a dual carriage without primary_carriage has its own axis (the
      // second pair of an IDEX axis; parked here).
      if (c.axis != "x" && c.axis != "y") {
        throw Error(fmt::format("carriage {}: a dual carriage without primary_carriage needs axis "
                                "x or y, got '{}'",
                                name, c.axis));
      }
    } else {
      const auto it = m.carriages.find(c.primary_carriage);
      const bool ok = it != m.carriages.end() && it->first != name &&
                      (it->second.type == Carriage::Type::primary ||
                       (it->second.type == Carriage::Type::dual && it->second.primary_carriage.empty()) ||
                       (c.type == Carriage::Type::extra && it->second.type == Carriage::Type::dual));
      if (!ok) {
        throw Error(fmt::format("carriage {}: primary_carriage '{}' must name a [carriage] "
                                "section{}",
                                name, c.primary_carriage,
                                c.type == Carriage::Type::extra ? " or a [dual_carriage]" : ""));
      }
      const std::string& primary_axis = axis_of(m, c.primary_carriage);
      if (c.type == Carriage::Type::dual) {
        if (primary_axis == "z") {
          throw Error(fmt::format("carriage {}: a dual carriage must be on axis x or y, got z", name));
        }
        if (!c.axis.empty() && c.axis != primary_axis) {
          throw Error(fmt::format("carriage {}: axis {} does not match its primary carriage {} "
                                  "(axis {})",
                                  name, c.axis, c.primary_carriage, primary_axis));
        }
        for (const auto& [other_name, other] : m.carriages) {
          if (other_name < name && other.type == Carriage::Type::dual &&
              other.primary_carriage == c.primary_carriage) {
            throw Error(fmt::format("carriage {}: {} is already the dual carriage of {}, "
                                    "expected one dual carriage per carriage",
                                    name, other_name, c.primary_carriage));
          }
        }
      } else if (!c.axis.empty()) {
        throw Error(fmt::format("carriage {}: an extra carriage takes its primary's axis, "
                                "expected no axis",
                                name));
      }
    }
    if (c.type != Carriage::Type::extra) {
      if (!c.position_max_mm) {
        throw Error(fmt::format("carriage {}: position_max must be given", name));
      }
      if (!c.position_endstop_mm) {
        throw Error(fmt::format("carriage {}: position_endstop must be given", name));
      }
      const double lo = c.position_min_mm.value_or(0.0);
      if (!(*c.position_max_mm > lo)) {
        throw Error(fmt::format("carriage {}: position_max ({} mm) must be > position_min ({} mm)",
                                name, *c.position_max_mm, lo));
      }
      if (*c.position_endstop_mm < lo || *c.position_endstop_mm > *c.position_max_mm) {
        throw Error(fmt::format("carriage {}: position_endstop ({} mm) must be between "
                                "position_min and position_max",
                                name, *c.position_endstop_mm));
      }
    }
  }
  for (std::size_t a = 0; a < 3; ++a) {
    if (primary[a].empty()) {
      throw Error(fmt::format("generic_cartesian: no carriage defined for axis '{}', expected a "
                              "[carriage] with axis {}",
                              "xyz"[a], "xyz"[a]));
    }
    const Carriage& c = m.carriages.at(primary[a]);
    g.limits_mm[a] = {c.position_min_mm.value_or(0.0), *c.position_max_mm};
  }
  // Steppers: every one but the extruders carries a carriages expression.
  std::vector<std::string> referenced;
  std::vector<std::vector<Term>> all_terms;
  for (const auto& [name, carriages] : m.stepper_carriages) {
    const std::string label = fmt::format("stepper_{}.carriages", name);
    if (carriages.empty()) {
      throw Error(fmt::format("{} must be given for a generic_cartesian stepper, e.g. "
                              "\"carriage_x+carriage_y\"",
                              label));
    }
    auto terms = carriage_terms(carriages, m, label);
    for (const auto& t : terms) referenced.push_back(t.first);
    g.steppers.push_back({name, row_of(terms, m, false)});
    all_terms.push_back(std::move(terms));
  }
  for (const auto& [name, c] : m.carriages) {
    if (std::find(referenced.begin(), referenced.end(), name) == referenced.end()) {
      throw Error(fmt::format("carriage {} must be referenced by some stepper's carriages", name));
    }
  }
  // generic_cartesian.py _check_kinematics: M^T M invertible, M the stepper rows, with the
  // primaries active and with the dual carriages active.
  const bool has_dual = std::any_of(m.carriages.begin(), m.carriages.end(), [](const auto& kv) {
    return kv.second.type == Carriage::Type::dual;
  });
  for (const bool dual_active : {false, true}) {
    if (dual_active && !has_dual) break;
    std::array<std::array<double, 3>, 3> mtm{};
    double scale = 0.0;
    for (const auto& terms : all_terms) {
      const auto r = row_of(terms, m, dual_active);
      for (std::size_t i = 0; i < 3; ++i) {
        for (std::size_t j = 0; j < 3; ++j) mtm[i][j] += r[i] * r[j];
        scale = std::max(scale, std::abs(r[i]));
      }
    }
    const double det = mtm[0][0] * (mtm[1][1] * mtm[2][2] - mtm[1][2] * mtm[2][1]) -
                       mtm[0][1] * (mtm[1][0] * mtm[2][2] - mtm[1][2] * mtm[2][0]) +
                       mtm[0][2] * (mtm[1][0] * mtm[2][1] - mtm[1][1] * mtm[2][0]);
    if (!(std::abs(det) > 1e-12 * std::pow(scale * scale, 3.0))) {
      throw Error(fmt::format("generic_cartesian: the steppers' carriages do not move X, Y and Z "
                              "independently{}, expected stepper carriages such as x+y, x-y, z",
                              dual_active ? " with the dual carriages active" : ""));
    }
  }
  return g;
}

std::string stepper_carriages_error(const GenericCartesian& m,
                                    const std::map<std::string, std::string, std::less<>>& now,
                                    const std::string& stepper, const std::string& expr,
                                    bool full) {
  const auto it = now.find(stepper);
  if (it == now.end()) return fmt::format("invalid STEPPER '{}' specified", stepper);
  const std::string label = fmt::format("stepper {} CARRIAGES", stepper);
  try {
    const auto old_terms = carriage_terms(it->second, m, label);
    const auto new_terms = carriage_terms(expr, m, label);
    bool same = old_terms.size() == new_terms.size();
    double sum = 0.0;
    for (std::size_t i = 0; i < new_terms.size(); ++i) {
      same = same && old_terms[i].first == new_terms[i].first;
      sum += std::abs(new_terms[i].second);
    }
    if (!(sum > 0.0)) return fmt::format("'{}' must provide a valid 'carriages' expression", expr);
    if (!same) {
      return fmt::format("'{}' cannot add or remove carriages that stepper {} controls ('{}')",
                         expr, stepper, it->second);
    }
    if (full) {
      GenericCartesian changed = m;
      for (const auto& [name, e] : now) {
        const auto s = changed.stepper_carriages.find(name);
        if (s != changed.stepper_carriages.end()) s->second = name == stepper ? expr : e;
      }
      (void)generic_cartesian_geometry(changed);
    }
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

namespace {

bool extruder_key(const std::string& k) {
  return k[0] == 'e' && std::all_of(k.begin() + 1, k.end(), [](char c) { return c >= '0' && c <= '9'; });
}

class GenericCartesianKinematics final : public Kinematics {
 public:
  GenericCartesianKinematics(const GenericCartesian& p, const Context& ctx)
      : p_(p), th_(ctx.toolhead), g_(generic_cartesian_geometry(p)) {}
  std::string_view name() const override { return GenericCartesian::kName; }
  std::vector<Motor> motors(const std::vector<std::string>& keys,
                            std::vector<std::string>&) const override {
    for (const std::string& k : keys) {
      if (!extruder_key(k) && p_.stepper_carriages.count(k) == 0) {
        throw Error(fmt::format("stepper_{}.carriages must be given for a generic_cartesian "
                                "stepper, e.g. \"carriage_x+carriage_y\"",
                                k));
      }
    }
    std::vector<Motor> out;
    for (const GenericStepper& gs : g_.steppers) {
      if (std::find(keys.begin(), keys.end(), gs.name) == keys.end()) continue;
      Motor m;
      m.key = gs.name;
      m.name = "stepper " + gs.name;  // Klipper's name of a [stepper NAME]
      m.row = {gs.coeffs[0], gs.coeffs[1], gs.coeffs[2], 0.0};
      out.push_back(std::move(m));
    }
    return out;
  }
  MoveRules move_rules() const override {
    // generic_cartesian.py: the ranges of the primary carriages, checked as cartesian.py does.
    MoveRules r;
    r.z_velocity_mm_s = th_.max_z_velocity_mm_s > 0 ? th_.max_z_velocity_mm_s : th_.max_velocity_mm_s;
    r.z_accel_mm_s2 = th_.max_z_accel_mm_s2 > 0 ? th_.max_z_accel_mm_s2 : th_.max_accel_mm_s2;
    for (std::size_t i = 0; i < 3; ++i) {
      r.range_min_mm[i] = g_.limits_mm[i][0];
      r.range_max_mm[i] = g_.limits_mm[i][1];
    }
    return r;
  }
  Homing homing() const override {
    // generic_cartesian.py home_axis: a homed axis ends at its primary carriage's
    // position_endstop (the dual carriage's pair too: idex_modes.py home() ends with the
    // primary carriage active).
    Homing h;
    h.klipper_only = true;
    for (const auto& [name, c] : p_.carriages) {
      if (c.type != Carriage::Type::primary || c.axis.size() != 1 || !c.position_endstop_mm) continue;
      h.position_mm[static_cast<std::size_t>(c.axis[0] - 'x')] = *c.position_endstop_mm;
    }
    return h;
  }
  std::vector<IdexPair> idex_pairs() const override {
    // IDEX (idex_modes.py through generic_cartesian.py): one pair per [dual_carriage NAME]
    // with its primary carriage. A dual carriage without primary_carriage (a second pair on
    // one axis) is not modelled: all dual carriages then stay parked.
    const auto& cs = p_.carriages;
    std::vector<IdexPair> out;
    const bool pairs_only = std::all_of(cs.begin(), cs.end(), [](const auto& kv) {
      return kv.second.type != Carriage::Type::dual || !kv.second.primary_carriage.empty();
    });
    if (!pairs_only) return out;
    for (const char axis : {'x', 'y'}) {
      for (const auto& [name, dual] : cs) {
        if (dual.type != Carriage::Type::dual) continue;
        const auto pit = cs.find(dual.primary_carriage);
        if (pit == cs.end() || pit->second.axis != std::string(1, axis)) continue;
        const Carriage& first = pit->second;
        IdexPair d;
        d.axis = axis - 'x';
        d.names = {pit->first, name};
        d.position_min_mm = {first.position_min_mm.value_or(0.0), dual.position_min_mm.value_or(0.0)};
        d.position_max_mm = {first.position_max_mm.value_or(0.0), dual.position_max_mm.value_or(0.0)};
        d.position_endstop_mm = {first.position_endstop_mm.value_or(0.0),
                                 dual.position_endstop_mm.value_or(0.0)};
        d.safe_distance_mm = dual.safe_distance_mm;
        d.homing_speed_mm_s = {first.homing_speed_mm_s, dual.homing_speed_mm_s};
        out.push_back(d);
      }
    }
    return out;
  }
  std::map<std::string, std::string, std::less<>> stepper_carriages() const override {
    std::map<std::string, std::string, std::less<>> out;
    for (const auto& [name, e] : p_.stepper_carriages) {
      if (!e.empty()) out[name] = e;
    }
    return out;
  }
  std::string stepper_carriages_error(const std::map<std::string, std::string, std::less<>>& now,
                                      const std::string& stepper, const std::string& expr,
                                      bool full) const override {
    return kinematics::stepper_carriages_error(p_, now, stepper, expr, full);
  }
  std::optional<LinearMap> linear_map() const override {
    LinearMap map;
    for (const GenericStepper& gs : g_.steppers) {
      map.motors.push_back("stepper " + gs.name);
      map.rows.push_back(gs.coeffs);
    }
    return map;
  }
  void describe(Json& j) const override {
    // The carriages as given, and each stepper's row over X, Y, Z (dual carriages parked).
    Json carriages = Json::object();
    static constexpr const char* kTypes[] = {"carriage", "extra_carriage", "dual_carriage"};
    for (const auto& [name, c] : p_.carriages) {
      Json cj = {{"type", kTypes[static_cast<std::size_t>(c.type)]}};
      if (!c.axis.empty()) cj["axis"] = c.axis;
      if (!c.primary_carriage.empty()) cj["primary_carriage"] = c.primary_carriage;
      if (c.position_min_mm) cj["position_min"] = *c.position_min_mm;
      if (c.position_max_mm) cj["position_max"] = *c.position_max_mm;
      if (c.position_endstop_mm) cj["position_endstop"] = *c.position_endstop_mm;
      carriages[name] = cj;
    }
    j["carriages"] = carriages;
    Json rows = Json::object();
    for (const GenericStepper& gs : g_.steppers) rows[gs.name] = {gs.coeffs[0], gs.coeffs[1], gs.coeffs[2]};
    j["stepper_rows_xyz"] = rows;
  }

 private:
  GenericCartesian p_;
  Toolhead th_;
  GenericCartesianGeometry g_;
};

}  // namespace

bool generic_stepper_name(std::string_view name) {
  if (name.empty()) return false;
  if (!std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
      })) {
    return false;
  }
  return !extruder_key(std::string(name));
}

namespace {

std::string name_after(const std::string& section, std::string_view prefix) {
  if (section.rfind(prefix, 0) != 0) return {};
  std::string rest(trim(std::string_view(section).substr(prefix.size())));
  const std::size_t space = rest.find_last_of(" \t");
  return space == std::string::npos ? rest : rest.substr(space + 1);
}

}  // namespace

std::vector<KlipperStepper> GenericCartesian::klipper_steppers(const KlipperConfig& cfg) {
  std::vector<KlipperStepper> out;
  for (const ConfigSection& s : cfg.sections()) {
    const std::string name = name_after(s.name, "stepper ");
    if (name.empty()) continue;
    if (!generic_stepper_name(name)) {
      throw Error(s.where, fmt::format("[{}]: amctl names a generic_cartesian stepper by the word "
                                       "after 'stepper', expected letters, digits and _ other than "
                                       "e, e1, ... (the extruders'), got '{}'",
                                       s.name, name));
    }
    out.push_back({s.name, name, false});
  }
  return out;
}

GenericCartesian GenericCartesian::from_klipper(const KlipperConfig& cfg) {
  GenericCartesian g;
  for (ConfigSection& s : cfg.sections()) {
    Carriage c;
    std::string name;
    if (!(name = name_after(s.name, "carriage ")).empty()) {
      c.type = Carriage::Type::primary;
    } else if (!(name = name_after(s.name, "extra_carriage ")).empty()) {
      c.type = Carriage::Type::extra;
    } else if (!(name = name_after(s.name, "dual_carriage ")).empty()) {
      c.type = Carriage::Type::dual;
    } else if (!(name = name_after(s.name, "stepper ")).empty()) {
      g.stepper_carriages[name] = cfg.section(s.name).require_text("carriages");
      continue;
    } else {
      continue;
    }
    const KlipperSection sec = cfg.section(s.name);
    if (c.type == Carriage::Type::primary) {
      const bool named_axis = name == "x" || name == "y" || name == "z";
      c.axis = named_axis ? sec.get_choice("axis", name, {"x", "y", "z"})
                          : sec.get_choice("axis", "", {"x", "y", "z"});
      if (c.axis.empty()) (void)sec.require_text("axis");  // throws: missing
    } else if (c.type == Carriage::Type::extra) {
      c.primary_carriage = sec.require_text("primary_carriage");
    } else {
      // A dual carriage names its primary_carriage (axis optional, must match it) or, without
      // one, its own axis (generic_cartesian.py DualCarriage).
      if (sec.has("primary_carriage")) {
        c.primary_carriage = sec.require_text("primary_carriage");
        c.axis = sec.get_choice("axis", "", {"x", "y", "z"});
      } else {
        c.axis = sec.get_choice("axis", "", {"x", "y", "z"});
        if (c.axis.empty()) (void)sec.require_text("axis");  // throws: missing
      }
    }
    if (c.type != Carriage::Type::extra) {
      c.position_endstop_mm = sec.require_float("position_endstop");
      c.position_min_mm = sec.get_float("position_min", 0.0);
      c.position_max_mm = sec.require_float("position_max", {.above = *c.position_min_mm});
      c.homing_speed_mm_s = sec.get_float("homing_speed", 5.0, {.above = 0.0});
    }
    if (c.type == Carriage::Type::dual && !c.primary_carriage.empty()) {
      c.safe_distance_mm = sec.get_float("safe_distance", {.minval = 0.0});
    }
    if (g.carriages.count(name) != 0) {
      throw Error(s.where, fmt::format("[{}]: carriage '{}' is defined twice, expected one section "
                                       "per carriage name",
                                       s.name, name));
    }
    g.carriages[name] = c;
  }
  if (g.carriages.empty()) {
    throw Error(cfg.printer_where(), "a generic_cartesian printer needs [carriage NAME] sections (one "
                                     "per axis x, y, z) and [stepper NAME] sections with carriages");
  }
  detail::refuse_dual_carriage(cfg);
  return g;
}

namespace {

constexpr std::string_view kCarriageTypes[] = {"carriage", "extra_carriage", "dual_carriage"};
constexpr std::string_view kAxes[] = {"x", "y", "z"};

Carriage* carriage_of(GenericCartesian& g, std::string_view name, bool create) {
  if (name.empty()) return nullptr;
  if (create) return &g.carriages[std::string(name)];
  const auto it = g.carriages.find(std::string(name));
  return it == g.carriages.end() ? nullptr : &it->second;
}

std::vector<std::string> carriage_names(const GenericCartesian& g) {
  std::vector<std::string> out;
  for (const auto& [name, c] : g.carriages) out.push_back(name);
  return out;
}

}  // namespace

std::span<const ParamKey<GenericCartesian>> GenericCartesian::keys() {
  using G = GenericCartesian;
  using Opt = std::optional<double>;
  static const std::vector<ParamKey<G>> keys = {
      {"carriage", "type", KeyBound::finite, "",
       "generic_cartesian carriages ([carriage.NAME]): carriage (moves its axis), "
       "extra_carriage (moves with its primary) or dual_carriage (the second carriage of an IDEX "
       "axis, parked).",
       nullptr, nullptr, nullptr, kCarriageTypes, carriage_names,
       [](G& g, std::string_view i) -> int {
         const Carriage* k = carriage_of(g, i, false);
         return k ? static_cast<int>(k->type) : -1;
       },
       [](G& g, std::string_view i, int index) -> bool {
         Carriage* k = carriage_of(g, i, true);
         if (k != nullptr) k->type = static_cast<Carriage::Type>(index);
         return k != nullptr;
       }},
      {"carriage", "axis", KeyBound::finite, "",
       "The axis a carriage moves: x, y or z (primary carriages; a dual carriage without "
       "primary_carriage).",
       nullptr, nullptr,
       [](G& g, std::string_view i, bool c) -> std::string* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->axis : nullptr;
       },
       kAxes, carriage_names},
      {"carriage", "primary_carriage", KeyBound::finite, "",
       "Extra and dual carriages: the carriage they belong to.", nullptr, nullptr,
       [](G& g, std::string_view i, bool c) -> std::string* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->primary_carriage : nullptr;
       },
       {}, carriage_names},
      {"carriage", "position_min", KeyBound::finite, "mm",
       "Carriage range: lowest position (Klipper position_min; unset = 0).",
       [](G& g, std::string_view i, bool c) -> Opt* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->position_min_mm : nullptr;
       },
       nullptr, nullptr, {}, carriage_names},
      {"carriage", "position_max", KeyBound::finite, "mm",
       "Carriage range: highest position (Klipper position_max; required on primary and dual "
       "carriages).",
       [](G& g, std::string_view i, bool c) -> Opt* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->position_max_mm : nullptr;
       },
       nullptr, nullptr, {}, carriage_names},
      {"carriage", "position_endstop", KeyBound::finite, "mm",
       "Where homing leaves the carriage (Klipper position_endstop; required on primary and dual "
       "carriages).",
       [](G& g, std::string_view i, bool c) -> Opt* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->position_endstop_mm : nullptr;
       },
       nullptr, nullptr, {}, carriage_names},
      {"carriage", "homing_speed", KeyBound::positive, "mm/s",
       "Carriage homing speed (Klipper homing_speed; RESTORE_DUAL_CARRIAGE_STATE moves an IDEX "
       "pair at the lower one).",
       nullptr,
       [](G& g, std::string_view i, bool c) -> double* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->homing_speed_mm_s : nullptr;
       },
       nullptr, {}, carriage_names},
      {"carriage", "safe_distance", KeyBound::non_negative, "mm",
       "Dual carriages: the closest the pair may come (Klipper safe_distance; unset = from the "
       "rails).",
       [](G& g, std::string_view i, bool c) -> Opt* {
         Carriage* k = carriage_of(g, i, c);
         return k ? &k->safe_distance_mm : nullptr;
       },
       nullptr, nullptr, {}, carriage_names},
      {"stepper", "carriages", KeyBound::finite, "",
       "generic_cartesian steppers: the carriages the stepper moves, as a linear combination "
       "(Klipper carriages: \"carriage_x+carriage_y\", \"carriage_u-carriage_y1\", "
       "\"1*carriage_y+0.5*carriage_z\").",
       nullptr, nullptr,
       [](G& g, std::string_view i, bool c) -> std::string* {
         if (!generic_stepper_name(i)) return nullptr;
         if (c) return &g.stepper_carriages[std::string(i)];
         const auto it = g.stepper_carriages.find(std::string(i));
         return it == g.stepper_carriages.end() ? nullptr : &it->second;
       }},
  };
  return keys;
}

std::unique_ptr<Kinematics> make_kinematics(const GenericCartesian& p, const Context& ctx) {
  return std::make_unique<GenericCartesianKinematics>(p, ctx);
}

}  // namespace amctl::kinematics
