#include "amctl/machine/linkage.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/delta.hpp"

namespace amctl::machine {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

using Term = std::pair<std::string, double>;

/// The axis a carriage moves: its own (a primary, a dual carriage that names one) or its
/// primary's (extra carriages, dual carriages without an axis of their own).
const std::string& axis_of(const Machine& m, const std::string& name) {
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
std::vector<Term> carriage_terms(std::string_view expr, const Machine& m, std::string_view label) {
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
bool carriage_active(const Machine& m, const std::string& name, bool dual_active, int depth = 0) {
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

std::array<double, 3> row_of(const std::vector<Term>& terms, const Machine& m, bool dual_active) {
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

std::array<double, 3> parse_carriages(std::string_view expr, const Machine& m,
                                      std::string_view label, bool with_dual) {
  return row_of(carriage_terms(expr, m, label), m, with_dual);
}

GenericCartesianGeometry generic_cartesian_geometry(const Machine& m) {
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
  for (const auto& [name, s] : m.steppers) {
    if (name == "e" || (name[0] == 'e' && name.size() > 1 &&
                        std::all_of(name.begin() + 1, name.end(), ::isdigit))) {
      continue;
    }
    const std::string label = fmt::format("stepper_{}.carriages", name);
    if (s.carriages.empty()) {
      throw Error(fmt::format("{} must be given for a generic_cartesian stepper, e.g. "
                              "\"carriage_x+carriage_y\"",
                              label));
    }
    auto terms = carriage_terms(s.carriages, m, label);
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

std::string stepper_carriages_error(const Machine& m,
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
      Machine changed = m;
      for (const auto& [name, e] : now) {
        const auto s = changed.steppers.find(name);
        if (s != changed.steppers.end()) s->second.carriages = name == stepper ? expr : e;
      }
      (void)generic_cartesian_geometry(changed);
    }
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

PolarGeometry polar_geometry(const Machine& m) {
  PolarGeometry g;
  for (const char* name : {"bed", "arm", "z"}) {
    if (m.steppers.find(name) == m.steppers.end()) {
      throw Error(fmt::format("a polar printer needs stepper_bed, stepper_arm and stepper_z; "
                              "stepper_{} is missing",
                              name));
    }
  }
  const Stepper& arm = m.steppers.at("arm");
  const Stepper& z = m.steppers.at("z");
  if (!arm.position_max_mm) throw Error("stepper_arm.position_max must be given for a polar printer");
  if (!arm.position_endstop_mm) {
    throw Error("stepper_arm.position_endstop must be given for a polar printer");
  }
  if (!z.position_max_mm) throw Error("stepper_z.position_max must be given for a polar printer");
  g.max_radius_mm = *arm.position_max_mm;
  g.arm_endstop_mm = *arm.position_endstop_mm;
  g.z_limits_mm = {z.position_min_mm.value_or(0.0), *z.position_max_mm};
  return g;
}

double RotaryDeltaGeometry::arm_angle_rad(int arm, double x, double y, double z) const {
  const auto i = static_cast<std::size_t>(arm);
  const double ca = std::cos(angle_rad[i]), sa = std::sin(angle_rad[i]);
  const double u = x * ca + y * sa - shoulder_radius_mm;  // outward in the arm's plane
  const double v = z - shoulder_height_mm;                // up
  const double w = y * ca - x * sa;                       // off the plane
  const double l2 = lower_arm_mm[i] * lower_arm_mm[i] - w * w;
  const double u2 = upper_arm_mm[i] * upper_arm_mm[i];
  const double p2 = u * u + v * v;
  const double p = std::sqrt(p2);
  // e . p = (|p|^2 + U^2 - l^2) / 2 = U |p| cos(alpha - phi).
  const double c = (p2 + u2 - l2) / (2.0 * upper_arm_mm[i] * p);
  if (!(c >= -1.0 && c <= 1.0)) return std::numeric_limits<double>::quiet_NaN();
  const double phi = std::atan2(v, u), delta = std::acos(c);
  const double a1 = phi + delta, a2 = phi - delta;
  // The outer elbow (larger horizontal coordinate).
  return std::cos(a1) >= std::cos(a2) ? std::remainder(a1, 2.0 * std::numbers::pi)
                                      : std::remainder(a2, 2.0 * std::numbers::pi);
}

std::array<double, 3> RotaryDeltaGeometry::elbow_mm(int arm, double angle) const {
  const auto i = static_cast<std::size_t>(arm);
  const double r = upper_arm_mm[i] * std::cos(angle) + shoulder_radius_mm;
  return {r * std::cos(angle_rad[i]), r * std::sin(angle_rad[i]),
          upper_arm_mm[i] * std::sin(angle) + shoulder_height_mm};
}

double RotaryDeltaGeometry::limit_xy2_at(double z) const {
  if (z <= limit_z_mm) return max_xy2_mm2;
  return std::min(max_xy2_mm2, (max_z_mm - z) * (max_z_mm - z));
}

RotaryDeltaGeometry rotary_delta_geometry(const Machine& m) {
  RotaryDeltaGeometry g;
  if (!m.delta.shoulder_radius_mm) throw Error("delta.shoulder_radius must be given for a rotary delta");
  if (!m.delta.shoulder_height_mm) throw Error("delta.shoulder_height must be given for a rotary delta");
  g.shoulder_radius_mm = *m.delta.shoulder_radius_mm;
  g.shoulder_height_mm = *m.delta.shoulder_height_mm;
  const Stepper* arms[3] = {nullptr, nullptr, nullptr};
  for (int i = 0; i < 3; ++i) {
    const std::string name(1, static_cast<char>('a' + i));
    const auto it = m.steppers.find(name);
    if (it == m.steppers.end()) {
      throw Error(fmt::format("a rotary delta needs stepper_a, stepper_b and stepper_c; "
                              "stepper_{} is missing",
                              name));
    }
    arms[i] = &it->second;
  }
  const Stepper& a = *arms[0];
  if (!a.upper_arm_length_mm) throw Error("stepper_a.upper_arm_length must be given for a rotary delta");
  if (!a.lower_arm_length_mm) throw Error("stepper_a.lower_arm_length must be given for a rotary delta");
  if (!a.position_endstop_mm) throw Error("stepper_a.position_endstop must be given for a rotary delta");
  constexpr double kDefaultAngles[] = {30.0, 150.0, 270.0};  // rotary_delta.py
  for (std::size_t i = 0; i < 3; ++i) {
    const Stepper& s = *arms[i];
    g.upper_arm_mm[i] = s.upper_arm_length_mm.value_or(*a.upper_arm_length_mm);
    g.lower_arm_mm[i] = s.lower_arm_length_mm.value_or(*a.lower_arm_length_mm);
    g.angle_rad[i] = s.angle_deg.value_or(kDefaultAngles[i]) * std::numbers::pi / 180.0;
    g.endstop_mm[i] = s.position_endstop_mm.value_or(*a.position_endstop_mm);
    if (!(g.lower_arm_mm[i] > g.shoulder_radius_mm)) {
      throw Error(fmt::format("stepper_{}.lower_arm_length ({} mm) must be > delta.shoulder_radius "
                              "({} mm)",
                              "abc"[i], g.lower_arm_mm[i], g.shoulder_radius_mm));
    }
  }
  std::array<std::array<double, 3>, 3> elbows{};
  std::array<double, 3> lower2{};
  for (int i = 0; i < 3; ++i) {
    const auto k = static_cast<std::size_t>(i);
    g.endstop_angle_rad[k] = g.arm_angle_rad(i, 0.0, 0.0, g.endstop_mm[k]);
    if (!std::isfinite(g.endstop_angle_rad[k])) {
      throw Error(fmt::format("stepper_{}.position_endstop ({} mm): the arms cannot reach the "
                              "centre at that height",
                              "abc"[k], g.endstop_mm[k]));
    }
    elbows[k] = g.elbow_mm(i, g.endstop_angle_rad[k]);
    lower2[k] = g.lower_arm_mm[k] * g.lower_arm_mm[k];
  }
  g.home_position_mm = trilaterate_below(elbows, lower2);
  g.max_z_mm = std::min({g.endstop_mm[0], g.endstop_mm[1], g.endstop_mm[2]});
  g.min_z_mm = m.delta.minimum_z_position_mm.value_or(0.0);
  if (g.min_z_mm > g.max_z_mm) {
    throw Error(fmt::format("delta.minimum_z_position ({} mm) must be <= the lowest "
                            "position_endstop ({} mm)",
                            g.min_z_mm, g.max_z_mm));
  }
  double reach = std::numeric_limits<double>::infinity();
  g.limit_z_mm = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < 3; ++i) {
    reach = std::min({reach, g.shoulder_radius_mm + g.upper_arm_mm[i],
                      g.lower_arm_mm[i] - g.shoulder_radius_mm});
    g.limit_z_mm = std::min(g.limit_z_mm, elbows[i][2] - g.lower_arm_mm[i]);
  }
  g.max_xy2_mm2 = reach * reach;
  return g;
}

}  // namespace amctl::machine
