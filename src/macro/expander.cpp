// [gcode_macro] expansion (klippy/extras/gcode_macro.py GCodeMacro.cmd, gcode.py parameter
// parsing); see expander.hpp and docs/macros.md.
#include "amctl/macro/expander.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>

#include <fmt/format.h>

namespace amctl::macro {
namespace {

std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string_view strip(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

/// gcode.py is_traditional_gcode: a letter then a number ("G28", "M109", "G28.1").
bool is_traditional(std::string_view name) {
  const std::string u = upper(strip(name));
  if (u.size() < 2 || !std::isupper(static_cast<unsigned char>(u[0])) ||
      !std::isdigit(static_cast<unsigned char>(u[1]))) {
    return false;
  }
  double v = 0.0;
  const auto r = std::from_chars(u.data() + 1, u.data() + u.size(), v);
  return r.ec == std::errc() && r.ptr == u.data() + u.size();
}

Value coord(const std::array<double, 4>& p) {
  return Value::list({Value::number(p[0]), Value::number(p[1]), Value::number(p[2]),
                      Value::number(p[3])},
                     true);
}

/// A configfile setting: a number where the text is one (Klipper's getfloat), else the text.
Value setting(const std::string& text) {
  double v = 0.0;
  const std::string_view t = strip(text);
  const char* b = t.data();
  if (!t.empty() && t.front() == '+') ++b;
  const auto r = std::from_chars(b, t.data() + t.size(), v);
  if (!t.empty() && r.ec == std::errc() && r.ptr == t.data() + t.size() && std::isfinite(v)) {
    return Value::number(v);
  }
  return Value::string(text);
}

}  // namespace

bool extended_params(std::string_view raw, Dict& out) {
  std::vector<std::string> words;
  std::string cur;
  bool in_word = false;
  char quote = 0;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const char c = raw[i];
    if (quote == '\'') {
      if (c == '\'') quote = 0;
      else cur += c;
      continue;
    }
    if (quote == '"') {
      if (c == '"') {
        quote = 0;
      } else if (c == '\\' && i + 1 < raw.size() && (raw[i + 1] == '"' || raw[i + 1] == '\\')) {
        cur += raw[++i];
      } else {
        cur += c;
      }
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(std::move(cur));
      cur.clear();
      in_word = false;
    } else if (c == '#' || c == ';') {
      break;  // a comment to the end of the line
    } else if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (c == '\\' && i + 1 < raw.size()) {
      cur += raw[++i];
      in_word = true;
    } else {
      cur += c;
      in_word = true;
    }
  }
  if (quote != 0) return false;  // "No closing quotation"
  if (in_word) words.push_back(std::move(cur));
  for (const std::string& w : words) {
    const std::size_t eq = w.find('=');
    if (eq == std::string::npos) return false;
    out.set(upper(w.substr(0, eq)), Value::string(w.substr(eq + 1)));
  }
  return true;
}

Dict word_params(std::string_view line) {
  std::string_view code = strip(line);
  if (const std::size_t c = code.find(';'); c != std::string_view::npos) code = code.substr(0, c);
  const std::string u = upper(code);
  Dict out;
  std::size_t i = 0;
  // Skip text before the first key (re.split's first part).
  while (i < u.size() && !(std::isupper(static_cast<unsigned char>(u[i])) || u[i] == '_' || u[i] == '*')) ++i;
  while (i < u.size()) {
    const std::size_t k = i;
    if (u[i] == '*') {
      ++i;
    } else {
      while (i < u.size() && (std::isupper(static_cast<unsigned char>(u[i])) || u[i] == '_')) ++i;
    }
    const std::string key = u.substr(k, i - k);
    const std::size_t v = i;
    while (i < u.size() && !(std::isupper(static_cast<unsigned char>(u[i])) || u[i] == '_' || u[i] == '*')) ++i;
    out.set(key, Value::string(std::string(strip(std::string_view(u).substr(v, i - v)))));
  }
  return out;
}

std::string raw_params(std::string_view line, std::string_view command) {
  const std::string_view orig = strip(line);
  const std::string u = upper(orig);
  std::size_t start = command.size();
  std::size_t end = orig.size();
  if (u.compare(0, command.size(), command) != 0) {
    // A line number in front; a trailing checksum is not part of the parameters.
    const std::size_t at = u.find(command);
    start += at == std::string::npos ? 0 : at;
    const std::size_t star = orig.rfind('*');
    if (star != std::string_view::npos && star + 1 < orig.size() &&
        std::all_of(orig.begin() + static_cast<std::ptrdiff_t>(star) + 1, orig.end(),
                    [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; })) {
      end = star;
    }
  }
  start = std::min(start, orig.size());
  if (start < orig.size() && std::isspace(static_cast<unsigned char>(orig[start]))) ++start;
  return std::string(orig.substr(start, end > start ? end - start : 0));
}

MacroExpander::MacroExpander(std::span<const ConfigSection> config, const ToolheadInfo& toolhead,
                             RenderLimits limits)
    : toolhead_(toolhead), limits_(limits) {
  Dict settings, raw;
  for (const ConfigSection& s : config) {
    Dict typed, text;
    for (const auto& [key, value] : s.options) {
      typed.set(key, setting(value.text));
      text.set(key, Value::string(value.text));
    }
    // settings also holds the defaults the reader took (configfile.py access tracking);
    // config only what the file writes.
    for (const auto& [key, value] : s.defaults) {
      if (s.options.count(key) == 0) typed.set(key, setting(value));
    }
    settings.set(lower(s.name), Value::dict(std::move(typed)));
    raw.set(lower(s.name), Value::dict(std::move(text)));
    if (s.name == "extruder" || s.name == "heater_bed") heaters_.push_back(s.name);
  }
  Dict cf;
  cf.set("settings", Value::dict(std::move(settings)));
  cf.set("config", Value::dict(std::move(raw)));
  configfile_ = Value::dict(std::move(cf));

  for (const ConfigSection& s : config) {
    if (s.name.rfind("gcode_macro", 0) != 0) continue;
    std::vector<std::string> words;
    {
      std::string_view rest = s.name;
      while (!(rest = strip(rest)).empty()) {
        const std::size_t sp = rest.find_first_of(" \t");
        words.emplace_back(rest.substr(0, sp));
        rest = sp == std::string_view::npos ? std::string_view() : rest.substr(sp);
      }
    }
    if (words.front() != "gcode_macro") continue;  // e.g. [gcode_macros]
    if (words.size() != 2) {
      throw Error(s.where, fmt::format("Name of section '{}' contains illegal whitespace "
                                       "(Klipper refuses it; expected [gcode_macro NAME])",
                                       s.name));
    }
    Macro m;
    m.section = s.name;
    m.written = words[1];
    m.name = upper(words[1]);
    m.report.name = m.name;
    m.report.defined_at = s.where;
    const ConfigValue* gcode = s.find("gcode");
    if (gcode == nullptr) {
      throw Error(s.where, fmt::format("option 'gcode' in section [{}] must be specified", s.name));
    }
    m.gcode_at = gcode->where;
    m.gcode_lines = gcode->lines;
    const ConfigValue* desc = s.find("description");
    m.report.description = desc ? desc->text : "G-Code macro";
    if (by_name_.count(m.name) != 0) {
      throw Error(s.where, fmt::format("gcode command {} already registered (two [gcode_macro] "
                                       "sections of one name)",
                                       m.name));
    }
    if (const ConfigValue* rename = s.find("rename_existing")) {
      if (is_traditional(m.name) != is_traditional(rename->text)) {
        throw Error(rename->where, fmt::format("G-Code macro rename of different types ('{}' vs "
                                               "'{}')",
                                               m.name, rename->text));
      }
      renamed_[upper(strip(rename->text))] = m.name;
    }
    try {
      m.tmpl = Template::compile(gcode->text);
    } catch (const LimitError& e) {
      // A bound, not a construct to skip: the run stops here, as Klipper's config check would.
      throw Error(location(m, e.line()), fmt::format("macro {}: {}", m.name, e.what()));
    } catch (const TemplateError& e) {
      m.error = fmt::format("amctl cannot read the template at {}: {}", where(m, e.line()), e.what());
    }
    for (const auto& [key, value] : s.options) {
      if (key.rfind("variable_", 0) != 0) continue;
      try {
        m.variables.set(key.substr(9), parse_literal(value.text));
      } catch (const LimitError& e) {
        throw Error(value.where, fmt::format("option '{}': {}", key, e.what()));
      } catch (const TemplateError& e) {
        if (m.error.empty()) {
          m.error = fmt::format("option '{}' at {} is not a literal amctl reads: {}", key,
                                value.where.to_string(), e.what());
        }
      }
    }
    if (m.name == "G0" || m.name == "G1") expands_moves_ = true;
    by_name_[m.name] = macros_.size();
    macros_.push_back(std::move(m));
  }
}

SourceLocation MacroExpander::location(const Macro& m, std::uint32_t line) const {
  const std::uint64_t file_line =
      line >= 1 && line <= m.gcode_lines.size() ? m.gcode_lines[line - 1] : m.gcode_at.line;
  return SourceLocation{m.gcode_at.file, file_line, 0};
}

std::string MacroExpander::where(const Macro& m, std::uint32_t line) const {
  return location(m, line).to_string();
}

gcode::Expansion MacroExpander::skip(std::size_t macro, std::uint64_t line_no, std::string reason) {
  MacroReport& r = macros_[macro].report;
  ++r.skipped;
  if (r.skip_reason.empty()) {
    r.skip_reason = std::move(reason);
    r.first_skipped_line = line_no;
  }
  gcode::Expansion x;
  x.kind = gcode::Expansion::Kind::done;
  return x;
}

Value MacroExpander::printer_object(const gcode::InterpreterState& st) const {
  Dict p;
  Dict th;
  th.set("position", coord(st.position_mm));
  if (toolhead_.axis_minimum_mm && toolhead_.axis_maximum_mm) {
    const auto& lo = *toolhead_.axis_minimum_mm;
    const auto& hi = *toolhead_.axis_maximum_mm;
    th.set("axis_minimum", coord({lo[0], lo[1], lo[2], 0.0}));
    th.set("axis_maximum", coord({hi[0], hi[1], hi[2], 0.0}));
  }
  std::string homed;
  for (int a = 0; a < 3; ++a) {
    if ((st.homed_axes >> a) & 1u) homed += "xyz"[a];
  }
  th.set("homed_axes", Value::string(homed));
  th.set("max_velocity", Value::number(toolhead_.max_velocity_mm_s));
  th.set("max_accel", Value::number(toolhead_.max_accel_mm_s2));
  th.set("square_corner_velocity", Value::number(toolhead_.square_corner_velocity_mm_s));
  th.set("minimum_cruise_ratio", Value::number(toolhead_.minimum_cruise_ratio));
  th.set("extruder", Value::string(st.active_extruder));
  p.set("toolhead", Value::dict(std::move(th)));

  Dict gm;
  gm.set("speed_factor", Value::number(st.speed_factor));
  gm.set("speed", Value::number(st.feed_mm_min));
  gm.set("extrude_factor", Value::number(st.extrude_factor));
  gm.set("absolute_coordinates", Value::boolean(st.absolute_coordinates));
  gm.set("absolute_extrude", Value::boolean(st.absolute_extrude));
  gm.set("homing_origin", coord(st.homing_origin_mm));
  gm.set("position", coord(st.position_mm));
  gm.set("gcode_position", coord(st.gcode_position_mm));
  p.set("gcode_move", Value::dict(std::move(gm)));

  // Heaters: amctl does not model heating, so a heater is at its target (docs/macros.md).
  for (const std::string& h : heaters_) {
    const double target = h == "extruder" ? st.hotend_target_c : st.bed_target_c;
    Dict d;
    d.set("temperature", Value::number(target));
    d.set("target", Value::number(target));
    d.set("power", Value::number(0.0));
    if (h == "extruder") d.set("can_extrude", Value::boolean(true));
    p.set(h, Value::dict(std::move(d)));
  }
  if (st.exclude_object) {
    // exclude_object.py get_status: objects (each a dict with its name), excluded_objects,
    // current_object (None outside an object).
    List objects, excluded;
    for (const std::string& n : st.objects) {
      Dict o;
      o.set("name", Value::string(n));
      objects.push_back(Value::dict(std::move(o)));
    }
    for (const std::string& n : st.excluded_objects) excluded.push_back(Value::string(n));
    Dict eo;
    eo.set("objects", Value::list(std::move(objects)));
    eo.set("excluded_objects", Value::list(std::move(excluded)));
    eo.set("current_object", st.current_object ? Value::string(*st.current_object) : Value::none());
    p.set("exclude_object", Value::dict(std::move(eo)));
  }
  p.set("configfile", configfile_);
  for (const Macro& m : macros_) p.set(m.section, Value::dict(m.variables));
  return Value::dict(std::move(p));
}

gcode::Expansion MacroExpander::set_gcode_variable(std::string_view rawparams,
                                                   std::uint64_t line_no) {
  Dict params;
  std::string problem;
  Macro* target = nullptr;
  std::string variable;
  if (!extended_params(rawparams, params)) {
    problem = "malformed parameters (Klipper: \"Malformed command\")";
  } else {
    const Value* macro = params.find("MACRO");
    const Value* var = params.find("VARIABLE");
    const Value* value = params.find("VALUE");
    if (macro == nullptr || var == nullptr || value == nullptr) {
      problem = "needs MACRO=, VARIABLE= and VALUE=";
    } else {
      for (Macro& m : macros_) {
        if (m.written == macro->text()) target = &m;  // mux key: the name as written
      }
      variable = var->text();
      if (target == nullptr) {
        problem = fmt::format("no macro '{}' (Klipper: the value is not valid for MACRO)", macro->text());
      } else if (target->variables.find(variable) == nullptr) {
        problem = fmt::format("Unknown gcode_macro variable '{}'", variable);
      } else {
        try {
          target->variables.set(variable, parse_literal(value->text()));
        } catch (const LimitError& e) {
          throw Error(SourceLocation{"", line_no, 0}, fmt::format("SET_GCODE_VARIABLE VALUE: {}", e.what()));
        } catch (const TemplateError& e) {
          problem = fmt::format("unable to parse '{}' as a literal: {}", value->text(), e.what());
        }
      }
    }
  }
  gcode::Expansion x;
  x.kind = gcode::Expansion::Kind::done;
  if (problem.empty()) return x;
  if (!set_variable_report_) {
    set_variable_report_ = MacroReport{};
    set_variable_report_->name = "SET_GCODE_VARIABLE";
    set_variable_report_->description = "Set the value of a G-Code macro variable";
    set_variable_report_->first_line = line_no;
  }
  MacroReport& r = *set_variable_report_;
  ++r.calls;
  ++r.skipped;
  if (r.skip_reason.empty()) {
    r.skip_reason = problem + "; Klipper stops the print with this error";
    r.first_skipped_line = line_no;
  }
  return x;
}

gcode::Expansion MacroExpander::expand(const gcode::Command& cmd, std::string_view line,
                                       std::uint64_t line_no, const gcode::InterpreterState& state) {
  char buf[64];
  if (cmd.name.size() >= sizeof buf) return {};
  for (std::size_t i = 0; i < cmd.name.size(); ++i) {
    buf[i] = static_cast<char>(std::toupper(static_cast<unsigned char>(cmd.name[i])));
  }
  const std::string_view name(buf, cmd.name.size());
  const auto it = by_name_.find(name);
  if (it == by_name_.end()) {
    if (name == "SET_GCODE_VARIABLE") return set_gcode_variable(raw_params(line, name), line_no);
    if (const auto r = renamed_.find(name); r != renamed_.end()) {
      gcode::Expansion x;
      x.kind = gcode::Expansion::Kind::builtin;
      x.text = r->second + " " + std::string(cmd.args);
      return x;
    }
    return {};
  }
  const std::size_t id = it->second;
  Macro& m = macros_[id];
  if (m.report.calls++ == 0) {
    m.report.first_line = line_no;
    call_order_.push_back(id);
  }
  if (!m.error.empty()) return skip(id, line_no, m.error);
  if (m.in_script) {
    return skip(id, line_no, fmt::format("Macro {} called recursively (Klipper refuses it)", m.name));
  }
  if (depth_ >= 64) return skip(id, line_no, "macros nested more than 64 deep");
  // The work of one call with the macros it calls, and theirs, is bounded as a whole (a
  // macro calling the next twice, 40 deep, would make 2^40 calls).
  if (depth_ == 0) {
    tree_calls_ = 0;
    tree_bytes_ = 0;
    tree_root_line_ = line_no;
  }
  if (++tree_calls_ > limits_.max_calls_per_expansion) {
    throw Error(location(m, 0), fmt::format("macro {}: expansion limit: the call at G-code line {} makes more "
                                            "than {} macro calls, expected at most {}",
                                            m.name, tree_root_line_, limits_.max_calls_per_expansion,
                                            limits_.max_calls_per_expansion));
  }
  const std::string raw = raw_params(line, name);
  Dict params;
  if (is_traditional(m.name)) {
    params = word_params(line);
  } else if (!extended_params(raw, params)) {
    return skip(id, line_no, fmt::format("malformed parameters '{}' (Klipper: \"Malformed command\")", raw));
  }
  Dict globals = m.variables;
  globals.set("printer", printer_object(state));
  for (const char* fn : {"action_respond_info", "action_raise_error", "action_emergency_stop",
                         "action_call_remote_method"}) {
    globals.set(fn, Value::function(fn));
  }
  globals.set("params", Value::dict(std::move(params)));
  globals.set("rawparams", Value::string(raw));
  gcode::Expansion x;
  try {
    x.text = m.tmpl->render(globals, limits_);
  } catch (const LimitError& e) {
    throw Error(location(m, e.line()), fmt::format("macro {} (called at G-code line {}): {}", m.name, line_no,
                                                   e.what()));
  } catch (const TemplateError& e) {
    return skip(id, line_no, fmt::format("at {}: {}", where(m, e.line()), e.what()));
  }
  tree_bytes_ += x.text.size();
  if (tree_bytes_ > limits_.max_expansion_bytes) {
    throw Error(location(m, 0), fmt::format("macro {}: expansion limit: the call at G-code line {} produces "
                                            "more than {} MiB of G-code, expected at most {} MiB",
                                            m.name, tree_root_line_, limits_.max_expansion_bytes >> 20,
                                            limits_.max_expansion_bytes >> 20));
  }
  ++m.report.expanded;
  m.in_script = true;
  ++depth_;
  x.kind = gcode::Expansion::Kind::script;
  x.id = static_cast<std::uint32_t>(id);
  x.name = m.name;
  return x;
}

void MacroExpander::end_script(std::uint32_t id) {
  if (id < macros_.size() && macros_[id].in_script) {
    macros_[id].in_script = false;
    --depth_;
  }
}

std::vector<MacroReport> MacroExpander::reports() const {
  std::vector<MacroReport> out;
  for (std::size_t id : call_order_) out.push_back(macros_[id].report);
  if (set_variable_report_) out.push_back(*set_variable_report_);
  return out;
}

}  // namespace amctl::macro
