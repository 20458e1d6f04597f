// A Marlin machine from Configuration.h (+ Configuration_adv.h): include/amctl/machine/marlin.hpp.
#include <array>
#include <cctype>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"
#include "amctl/machine/marlin.hpp"
#include "marlin_common.hpp"

namespace amctl::machine {
namespace {

/// A #define: its value text and where that text starts.
struct Define {
  std::string value;
  SourceLocation where;
  bool certain = true;  ///< false: inside a conditional that could not be decided
};

/// Three-valued truth of a preprocessor condition: the derived HAS_* switches of Marlin's own
/// headers are not in the configuration files, so a condition on them is "maybe".
enum class Truth { no, maybe, yes };
Truth operator!(Truth t) { return t == Truth::yes ? Truth::no : t == Truth::no ? Truth::yes : Truth::maybe; }
Truth operator&&(Truth a, Truth b) {
  if (a == Truth::no || b == Truth::no) return Truth::no;
  return a == Truth::yes && b == Truth::yes ? Truth::yes : Truth::maybe;
}
Truth operator||(Truth a, Truth b) {
  if (a == Truth::yes || b == Truth::yes) return Truth::yes;
  return a == Truth::no && b == Truth::no ? Truth::no : Truth::maybe;
}

/// The #define lines of a C header that are not commented out (// or /* */), inside the
/// #if / #ifdef / #elif / #else blocks that apply. Conditions are Marlin's: ENABLED(),
/// DISABLED(), ANY(), EITHER(), ALL(), BOTH(), NONE(), defined(), !, &&, ||, comparisons of
/// numbers. A name no configuration file defines is 0 / disabled, except Marlin's derived
/// switches (HAS_*, IS_*, NEEDS_*), which make a condition "maybe": a define under a maybe is
/// used only when no definition surely applies. The first definition of a name wins.
class Defines {
 public:
  void read(std::string_view text, const std::string& source) {
    bool in_block = false;
    levels_.clear();
    for (const detail::MarlinLine& l : detail::split_lines(text)) {
      // Remove comments, keeping columns: /* ... */ (across lines) and // to the end.
      std::string line(l.text);
      for (std::size_t i = 0; i < line.size(); ++i) {
        if (in_block) {
          if (line.compare(i, 2, "*/") == 0) {
            line[i] = line[i + 1] = ' ';
            in_block = false;
            ++i;
          } else {
            line[i] = ' ';
          }
        } else if (line.compare(i, 2, "/*") == 0) {
          line[i] = line[i + 1] = ' ';
          in_block = true;
          ++i;
        } else if (line.compare(i, 2, "//") == 0) {
          line.resize(i);
          break;
        }
      }
      std::size_t at = line.find_first_not_of(" \t");
      if (at == std::string::npos || line[at] != '#') continue;
      ++at;
      while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
      std::size_t word_end = at;
      while (word_end < line.size() && std::isalpha(static_cast<unsigned char>(line[word_end]))) ++word_end;
      const std::string directive = line.substr(at, word_end - at);
      const std::string rest = line.substr(word_end);
      if (directive != "define") {
        conditional(directive, rest);
        continue;
      }
      if (active() == Truth::no) continue;
      at = word_end;
      if (at < line.size() && line[at] != ' ' && line[at] != '\t') continue;
      while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
      const std::size_t name_start = at;
      while (at < line.size() && (std::isalnum(static_cast<unsigned char>(line[at])) || line[at] == '_')) ++at;
      const std::string name = line.substr(name_start, at - name_start);
      if (name.empty() || (at < line.size() && line[at] == '(')) continue;  // function-like macro
      while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
      std::string value = line.substr(at);
      while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.pop_back();
      const bool certain = active() == Truth::yes;
      Define d{value, SourceLocation{source, l.number, static_cast<std::uint32_t>(at + 1)}, certain};
      const auto it = defs_.find(name);
      if (it == defs_.end()) {
        defs_.emplace(name, std::move(d));
      } else if (certain && !it->second.certain) {
        it->second = std::move(d);  // a definition that surely applies beats a maybe
      }
    }
  }
  [[nodiscard]] bool has(const std::string& name) const {
    const Define* d = get(name);
    return d != nullptr && d->value != "0" && d->value != "false";
  }
  [[nodiscard]] const Define* get(const std::string& name) const {
    const auto it = defs_.find(name);
    return it == defs_.end() ? nullptr : &it->second;
  }

  /// The number a define holds: a literal or an arithmetic expression (+ - * / and
  /// parentheses) of literals and other numeric defines.
  [[nodiscard]] std::optional<double> number(const std::string& name) const {
    const Define* d = get(name);
    if (d == nullptr) return std::nullopt;
    return eval(d->value, d->where, name, 0);
  }
  /// The numbers of a "{ a, b, c, d }" define (at least `min_count`).
  [[nodiscard]] std::optional<std::vector<double>> array(const std::string& name, std::size_t min_count) const {
    const Define* d = get(name);
    if (d == nullptr) return std::nullopt;
    std::string_view v = d->value;
    if (v.size() < 2 || v.front() != '{' || v.back() != '}') {
      throw Error(d->where, fmt::format("{}: found '{}', expected {{ x, y, z, e }}", name, d->value));
    }
    std::vector<double> out;
    std::size_t start = 1;
    for (std::size_t i = 1; i < v.size(); ++i) {
      if (v[i] == ',' || i + 1 == v.size()) {
        const std::string_view item = v.substr(start, i - start);
        if (item.find_first_not_of(" \t") != std::string_view::npos || v[i] == ',') {
          SourceLocation w = d->where;
          w.column += static_cast<std::uint32_t>(start);
          out.push_back(eval(item, w, name, 0));
        }
        start = i + 1;
      }
    }
    if (out.size() < min_count) {
      throw Error(d->where, fmt::format("{}: found {} values, expected at least {} (x, y, z, e)",
                                        name, out.size(), min_count));
    }
    return out;
  }

 private:
  double eval(std::string_view text, const SourceLocation& where, const std::string& name, int depth) const {
    if (depth > 16) {
      throw Error(where, fmt::format("{}: found a definition that refers to itself, expected a number", name));
    }
    std::size_t i = 0;
    auto fail = [&]() -> double {
      throw Error(where, fmt::format("{}: found '{}', expected a number or an arithmetic expression "
                                     "of numbers",
                                     name, text));
    };
    std::function<double()> expr, term, factor;
    auto blanks = [&] {
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    };
    factor = [&]() -> double {
      blanks();
      if (i >= text.size()) return fail();
      if (text[i] == '(') {
        ++i;
        const double v = expr();
        blanks();
        if (i >= text.size() || text[i] != ')') return fail();
        ++i;
        return v;
      }
      if (text[i] == '-') {
        ++i;
        return -factor();
      }
      if (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.') {
        const std::size_t s = i;
        while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '.' ||
                                   ((text[i] == '-' || text[i] == '+') && (text[i - 1] == 'e' || text[i - 1] == 'E')))) {
          ++i;
        }
        return detail::parse_marlin_number(text.substr(s, i - s), where, name);
      }
      if (std::isalpha(static_cast<unsigned char>(text[i])) || text[i] == '_') {
        const std::size_t s = i;
        while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_')) ++i;
        const std::string ref(text.substr(s, i - s));
        const Define* d = get(ref);
        if (d == nullptr) {
          throw Error(where, fmt::format("{}: found '{}', which is not defined here, expected a "
                                         "number",
                                         name, ref));
        }
        return eval(d->value, d->where, ref, depth + 1);
      }
      return fail();
    };
    term = [&]() -> double {
      double v = factor();
      for (;;) {
        blanks();
        if (i < text.size() && text[i] == '*') {
          ++i;
          v *= factor();
        } else if (i < text.size() && text[i] == '/') {
          ++i;
          const double d = factor();
          if (d == 0.0) return fail();
          v /= d;
        } else {
          return v;
        }
      }
    };
    expr = [&]() -> double {
      double v = term();
      for (;;) {
        blanks();
        if (i < text.size() && text[i] == '+') {
          ++i;
          v += term();
        } else if (i < text.size() && text[i] == '-') {
          ++i;
          v -= term();
        } else {
          return v;
        }
      }
    };
    const double v = expr();
    blanks();
    if (i != text.size()) return fail();
    return v;
  }

  /// One #if ... #endif level: whether its current branch applies, and whether an earlier
  /// branch of the chain did (or may have).
  struct Level {
    Truth parent = Truth::yes;
    Truth branch = Truth::yes;
    Truth taken = Truth::no;  ///< some earlier branch applied
  };
  [[nodiscard]] Truth active() const { return levels_.empty() ? Truth::yes : levels_.back().branch; }

  void conditional(const std::string& directive, const std::string& rest) {
    if (directive == "if" || directive == "ifdef" || directive == "ifndef") {
      Truth c = directive == "if" ? condition(rest) : is_defined(trim_copy(rest));
      if (directive == "ifndef") c = !c;
      Level l;
      l.parent = active();
      l.branch = l.parent && c;
      l.taken = c;
      levels_.push_back(l);
    } else if (directive == "elif" && !levels_.empty()) {
      Level& l = levels_.back();
      const Truth c = condition(rest);
      l.branch = l.parent && !l.taken && c;
      l.taken = l.taken || c;
    } else if (directive == "else" && !levels_.empty()) {
      Level& l = levels_.back();
      l.branch = l.parent && !l.taken;
      l.taken = Truth::yes;
    } else if (directive == "endif" && !levels_.empty()) {
      levels_.pop_back();
    } else if (directive == "undef" && active() == Truth::yes) {
      defs_.erase(trim_copy(rest));
    }
  }

  static std::string trim_copy(std::string_view s) {
    while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
    while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
    return std::string(s);
  }

  static bool derived(std::string_view name) {
    return name.starts_with("HAS_") || name.starts_with("IS_") || name.starts_with("NEEDS_");
  }

  [[nodiscard]] Truth is_defined(const std::string& name) const {
    if (name == "HAS_MEDIA") return enabled("SDSUPPORT");  // Marlin derives it from SDSUPPORT
    const Define* d = get(name);
    if (d != nullptr) return d->certain ? Truth::yes : Truth::maybe;
    return derived(name) ? Truth::maybe : Truth::no;
  }
  /// ENABLED(X): defined and not 0 / false.
  [[nodiscard]] Truth enabled(const std::string& name) const {
    const Truth t = is_defined(name);
    const Define* d = get(name);
    if (d != nullptr && (d->value == "0" || d->value == "false")) return Truth::no;
    return t;
  }

  /// A #if condition, three-valued. Values are numbers; a maybe poisons what it touches.
  [[nodiscard]] Truth condition(std::string_view text) const {
    struct Value {
      Truth known = Truth::yes;  // yes: `number` holds; maybe: unknown
      double number = 0.0;
    };
    std::size_t i = 0;
    auto blanks = [&] {
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    };
    auto truth = [](const Value& v) { return v.known == Truth::maybe ? Truth::maybe : (v.number != 0 ? Truth::yes : Truth::no); };
    auto of = [](Truth t) { return t == Truth::maybe ? Value{Truth::maybe, 0} : Value{Truth::yes, t == Truth::yes ? 1.0 : 0.0}; };
    auto ident = [&]() {
      const std::size_t s0 = i;
      while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '_')) ++i;
      return std::string(text.substr(s0, i - s0));
    };
    std::function<Value()> unary, comparison, conjunction, disjunction;
    auto arguments = [&]() {
      std::vector<std::string> args;
      blanks();
      if (i < text.size() && text[i] == '(') {
        ++i;
        for (;;) {
          blanks();
          args.push_back(ident());
          blanks();
          if (i < text.size() && text[i] == ',') {
            ++i;
            continue;
          }
          if (i < text.size() && text[i] == ')') ++i;
          break;
        }
      }
      return args;
    };
    unary = [&]() -> Value {
      blanks();
      if (i >= text.size()) return Value{Truth::maybe, 0};
      if (text[i] == '!') {
        ++i;
        return of(!truth(unary()));
      }
      if (text[i] == '(') {
        ++i;
        const Value v = disjunction();
        blanks();
        if (i < text.size() && text[i] == ')') ++i;
        return v;
      }
      if (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '-') {
        const std::size_t s0 = i++;
        while (i < text.size() && (std::isalnum(static_cast<unsigned char>(text[i])) || text[i] == '.')) ++i;
        try {
          return Value{Truth::yes, detail::parse_marlin_number(text.substr(s0, i - s0), {}, "")};
        } catch (const Error&) {
          return Value{Truth::maybe, 0};
        }
      }
      const std::string name = ident();
      if (name.empty()) {
        ++i;
        return Value{Truth::maybe, 0};
      }
      if (name == "ENABLED" || name == "DISABLED" || name == "ANY" || name == "EITHER" ||
          name == "ALL" || name == "BOTH" || name == "NONE" || name == "defined") {
        const std::vector<std::string> args = arguments();
        const bool all = name == "ALL" || name == "BOTH" || name == "ENABLED" || name == "defined";
        Truth t = all ? Truth::yes : Truth::no;
        for (const std::string& a : args) {
          const Truth e = name == "defined" ? is_defined(a) : enabled(a);
          t = all ? (t && e) : (t || e);
        }
        if (name == "DISABLED" || name == "NONE") t = !(name == "DISABLED" ? enabled(args.empty() ? "" : args[0]) : t);
        return of(t);
      }
      blanks();
      if (i < text.size() && text[i] == '(') {  // another macro call: not decided here
        int depth = 0;
        do {
          if (text[i] == '(') ++depth;
          if (text[i] == ')') --depth;
          ++i;
        } while (i < text.size() && depth > 0);
        return Value{Truth::maybe, 0};
      }
      const Define* d = get(name);
      if (d == nullptr) return of(is_defined(name));  // undefined: 0; derived: maybe
      if (!d->certain) return Value{Truth::maybe, 0};
      if (d->value.empty()) return Value{Truth::yes, 1};
      try {
        return Value{Truth::yes, eval(d->value, d->where, name, 0)};
      } catch (const Error&) {
        return Value{Truth::maybe, 0};
      }
    };
    comparison = [&]() -> Value {
      Value a = unary();
      for (;;) {
        blanks();
        std::string op;
        for (const char* o : {"==", "!=", "<=", ">=", "<", ">"}) {
          if (text.substr(i).starts_with(o)) {
            op = o;
            break;
          }
        }
        if (op.empty()) return a;
        i += op.size();
        const Value b = unary();
        if (a.known == Truth::maybe || b.known == Truth::maybe) {
          a = Value{Truth::maybe, 0};
          continue;
        }
        bool r = false;
        if (op == "==") r = a.number == b.number;
        if (op == "!=") r = a.number != b.number;
        if (op == "<=") r = a.number <= b.number;
        if (op == ">=") r = a.number >= b.number;
        if (op == "<") r = a.number < b.number;
        if (op == ">") r = a.number > b.number;
        a = Value{Truth::yes, r ? 1.0 : 0.0};
      }
    };
    conjunction = [&]() -> Value {
      Value a = comparison();
      for (;;) {
        blanks();
        if (!text.substr(i).starts_with("&&")) return a;
        i += 2;
        a = of(truth(a) && truth(comparison()));
      }
    };
    disjunction = [&]() -> Value {
      Value a = conjunction();
      for (;;) {
        blanks();
        if (!text.substr(i).starts_with("||")) return a;
        i += 2;
        a = of(truth(a) || truth(conjunction()));
      }
    };
    return truth(disjunction());
  }

  std::map<std::string, Define> defs_;
  std::vector<Level> levels_;
};

void set_axes(std::array<double, 4>& out, const std::vector<double>& v) {
  for (std::size_t a = 0; a < 4; ++a) out[a] = v[a];
}

}  // namespace

bool looks_like_marlin_configuration(std::string_view text) {
  // A "#define NAME" with an upper-case C name (a '#' comment of a TOML file or printer.cfg
  // that starts with "define" is prose), and no [section] line.
  bool define = false;
  for (const detail::MarlinLine& l : detail::split_lines(text)) {
    std::string_view t = l.text;
    while (!t.empty() && (t.front() == ' ' || t.front() == '\t')) t.remove_prefix(1);
    if (t.starts_with("[")) return false;
    if (!t.starts_with("#define") || t.size() < 9 || (t[7] != ' ' && t[7] != '\t')) continue;
    t.remove_prefix(8);
    while (!t.empty() && (t.front() == ' ' || t.front() == '\t')) t.remove_prefix(1);
    std::size_t n = 0;
    while (n < t.size() && (std::isupper(static_cast<unsigned char>(t[n])) || t[n] == '_' ||
                            (n > 0 && std::isdigit(static_cast<unsigned char>(t[n]))))) {
      ++n;
    }
    if (n > 0 && (n == t.size() || t[n] == ' ' || t[n] == '\t')) define = true;
  }
  return define;
}

Machine parse_marlin_configuration(std::string_view text, const std::string& source_name,
                                   std::string_view adv_text, const std::string& adv_name) {
  Defines d;
  d.read(text, source_name);
  if (!adv_text.empty()) d.read(adv_text, adv_name);
  const bool limits = d.has("DEFAULT_MAX_FEEDRATE") || d.has("DEFAULT_MAX_ACCELERATION") ||
                      d.has("DEFAULT_ACCELERATION");
  if (!limits) {
    throw Error(SourceLocation{source_name, 0, 0},
                "found no DEFAULT_MAX_FEEDRATE, DEFAULT_MAX_ACCELERATION or DEFAULT_ACCELERATION, "
                "expected Marlin's Configuration.h (Configuration_adv.h beside it is read with it)");
  }
  for (const char* k : {"DELTA", "MORGAN_SCARA", "MP_SCARA", "AXEL_TPARA", "POLARGRAPH", "POLAR"}) {
    if (const Define* x = d.get(k)) {
      throw Error(x->where, fmt::format("found {} kinematics, expected a cartesian, CoreXY, CoreXZ "
                                        "or Markforged printer: describe it in a machine .toml",
                                        k));
    }
  }
  Machine m = detail::marlin_base_machine(source_name);
  if (d.has("COREXY")) m.kinematics = kinematics::CoreXY{};
  if (d.has("COREXZ")) m.kinematics = kinematics::CoreXZ{};
  if (d.has("MARKFORGED_XY")) m.kinematics = kinematics::HybridCoreXY{};
  if (d.has("S_CURVE_ACCELERATION")) m.profile = VelocityProfile::bezier5;

  // Each limit in its physical range, placed at its #define (0 is Marlin's "unset").
  const auto in_range_at = [&d](const char* key, const PhysicalRange& r, const std::vector<double>& v) {
    for (const double x : v) {
      if (x != 0.0 && !in_range(r, x)) {
        throw Error(d.get(key)->where, fmt::format("{} must be {} values in [{:g}, {:g}] {}, got {:g}", key, r.quantity,
                                                   r.min, r.max, r.unit, x));
      }
    }
  };
  if (const auto v = d.array("DEFAULT_MAX_FEEDRATE", 4)) {
    in_range_at("DEFAULT_MAX_FEEDRATE", kSpeedRange, *v);
    set_axes(m.max_feedrate_mm_s, *v);
  }
  if (const auto v = d.array("DEFAULT_MAX_ACCELERATION", 4)) {
    in_range_at("DEFAULT_MAX_ACCELERATION", kAccelRange, *v);
    set_axes(m.max_axis_accel_mm_s2, *v);
  }
  if (const auto v = d.number("DEFAULT_ACCELERATION")) m.print_accel_mm_s2 = *v;
  if (const auto v = d.number("DEFAULT_RETRACT_ACCELERATION")) m.retract_accel_mm_s2 = *v;
  if (const auto v = d.number("DEFAULT_TRAVEL_ACCELERATION")) m.travel_accel_mm_s2 = *v;
  static constexpr const char* kJerk[4] = {"DEFAULT_XJERK", "DEFAULT_YJERK", "DEFAULT_ZJERK", "DEFAULT_EJERK"};
  for (std::size_t a = 0; a < 4; ++a) {
    if (const auto v = d.number(kJerk[a])) m.jerk_mm_s[a] = *v;
  }
  // Marlin 2.1: CLASSIC_JERK on = jerk, off = junction deviation (JUNCTION_DEVIATION_MM);
  // Marlin 1.1 had jerk unless JUNCTION_DEVIATION was defined.
  const bool jd = d.has("JUNCTION_DEVIATION_MM");
  if (d.has("CLASSIC_JERK") || (!jd && d.has("DEFAULT_XJERK"))) {
    m.junction = JunctionPolicy::classic_jerk;
  } else {
    m.junction = JunctionPolicy::junction_deviation;
    if (const auto v = d.number("JUNCTION_DEVIATION_MM")) m.junction_deviation_mm = *v;
  }
  if (const auto v = d.number("DEFAULT_NOMINAL_FILAMENT_DIA")) m.extruder.filament_diameter_mm = *v;
  static constexpr std::pair<const char*, const char*> kMicrosteps[4] = {
      {"x", "X_MICROSTEPS"}, {"y", "Y_MICROSTEPS"}, {"z", "Z_MICROSTEPS"}, {"e", "E0_MICROSTEPS"}};
  if (const auto steps = d.array("DEFAULT_AXIS_STEPS_PER_UNIT", 4)) {
    for (std::size_t a = 0; a < 4; ++a) {
      const auto micro = d.number(kMicrosteps[a].second);
      detail::set_steps_per_mm(m, kMicrosteps[a].first, (*steps)[a],
                               micro && *micro >= 1 ? static_cast<int>(*micro) : 16);
    }
  }
  for (int axis = 0; axis < 2; ++axis) {
    const std::string suffix = axis == 0 ? "X" : "Y";
    if (!d.has("INPUT_SHAPING_" + suffix)) continue;
    (axis == 0 ? m.input_shaper.shaper_type_x : m.input_shaper.shaper_type_y) = "zv";
    if (const auto v = d.number("SHAPING_FREQ_" + suffix)) {
      (axis == 0 ? m.input_shaper.shaper_freq_x_hz : m.input_shaper.shaper_freq_y_hz) = *v;
    }
    if (const auto v = d.number("SHAPING_ZETA_" + suffix)) {
      (axis == 0 ? m.input_shaper.damping_ratio_x : m.input_shaper.damping_ratio_y) = *v;
    }
  }
  // Configuration_adv.h.
  if (const auto v = d.number("DEFAULT_MINSEGMENTTIME")) m.min_segment_time_s = *v * 1e-6;
  if (const auto v = d.number("DEFAULT_MINIMUMFEEDRATE")) m.min_feedrate_mm_s = *v;
  if (const auto v = d.number("DEFAULT_MINTRAVELFEEDRATE")) m.min_travel_feedrate_mm_s = *v;
  if (const auto v = d.number("BLOCK_BUFFER_SIZE")) m.block_buffer_size = static_cast<int>(*v);
  if (!adv_text.empty()) m.arcs.enabled = d.has("ARC_SUPPORT");
  if (d.has("ARC_SUPPORT")) {
    if (const auto v = d.number("MM_PER_ARC_SEGMENT")) m.arcs.mm_per_arc_segment = *v;  // Marlin 1.1
    if (const auto v = d.number("MAX_ARC_SEGMENT_MM")) {
      m.arcs.mm_per_arc_segment = *v;
      m.arcs.max_arc_segment_mm = *v;
    }
    if (const auto v = d.number("MIN_ARC_SEGMENT_MM")) m.arcs.min_arc_segment_mm = *v;
    if (const auto v = d.number("MIN_CIRCLE_SEGMENTS")) m.arcs.min_circle_segments = static_cast<int>(*v);
    if (const auto v = d.number("ARC_SEGMENTS_PER_SEC")) m.arcs.segments_per_second = *v;
  }
  if (d.has("FWRETRACT")) {
    auto& r = m.firmware_retraction;
    if (const auto v = d.number("RETRACT_LENGTH")) r.retract_length_mm = *v;
    if (const auto v = d.number("RETRACT_FEEDRATE")) r.retract_speed_mm_s = *v;
    if (const auto v = d.number("RETRACT_ZRAISE")) r.lift_z_mm = *v;
    if (const auto v = d.number("RETRACT_RECOVER_LENGTH")) r.unretract_extra_length_mm = *v;
    if (const auto v = d.number("RETRACT_RECOVER_FEEDRATE")) r.unretract_speed_mm_s = *v;
  }
  detail::finish_marlin_machine(m, source_name);
  return m;
}

}  // namespace amctl::machine
