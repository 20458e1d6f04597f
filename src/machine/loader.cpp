// load_machine(): presets compiled in from configs/*.toml, TOML files, Klipper printer.cfg.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "amctl/core/input.hpp"
#include "amctl/core/text_input.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/marlin.hpp"
#include "schema.hpp"

namespace amctl::machine {
namespace {

namespace fs = std::filesystem;

std::string lowercase(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool looks_like_klipper(std::string_view text) {
  // An INI [printer] header and at least one "key: value" line. TOML never uses ':' between a
  // bare key and its value, so a file that fails to parse as TOML but has these is a cfg.
  bool printer = false;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? text.npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos) continue;
    line.remove_prefix(first);
    if (line.rfind("[printer]", 0) == 0) printer = true;
  }
  return printer;
}

/// A machine .toml file: as parse_machine_toml, but a file without a single setting (empty,
/// or only comments such as a C header's #define lines) is an error, not the default machine.
Machine parse_toml_file(const std::string& text, const std::string& spec) {
  bool empty = false;
  try {
    empty = toml::parse(text, spec).empty();
  } catch (const toml::parse_error&) {
    // parse_machine_toml reports it with its place
  }
  if (empty) {
    throw Error(SourceLocation{spec, 0, 0},
                "found no setting (the file is empty or only comments), expected a machine "
                "description: at least a [printer] section (docs/machine.md), a Klipper "
                "printer.cfg, Marlin's M503 output or its Configuration.h");
  }
  return parse_machine_toml(text, spec);
}

/// Every machine file is text (TOML, printer.cfg, M503 output, Configuration.h): a NUL byte is
/// damage (a capture from a serial console, a file cut and padded), refused at its line and
/// column before the format is told by the content (the TOML parser would otherwise be the one
/// to meet it and name the wrong format).
void refuse_nul_bytes(std::string_view text, const std::string& spec) {
  const std::size_t at = text.find('\0');
  if (at == std::string_view::npos) return;
  const std::string_view before = text.substr(0, at);
  std::size_t line = 1;
  std::size_t line_start = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    // Lines end at LF, CRLF or a lone CR, as the line reader counts them.
    if (before[i] == '\n' || (before[i] == '\r' && (i + 1 >= text.size() || text[i + 1] != '\n'))) {
      ++line;
      line_start = i + 1;
    }
  }
  throw Error(SourceLocation{spec, line, static_cast<std::uint32_t>(at - line_start + 1)},
              "found a NUL byte, expected text (a machine file is TOML, a Klipper printer.cfg, "
              "Marlin's M503 output or its Configuration.h)");
}

/// Configuration.h, with Configuration_adv.h from the same directory when there is one.
Machine load_marlin_configuration(const fs::path& path, const std::string& text,
                                  const std::string& spec) {
  std::string adv_text, adv_name;
  if (path.filename() == "Configuration.h") {
    const fs::path adv = path.parent_path() / "Configuration_adv.h";
    std::error_code ec;
    if (fs::is_regular_file(adv, ec)) {
      std::ifstream in(adv, std::ios::binary);
      std::ostringstream ss;
      ss << in.rdbuf();
      adv_text = ss.str();
      adv_name = (fs::path(spec).parent_path() / "Configuration_adv.h").string();
    }
  }
  return parse_marlin_configuration(text, spec, adv_text, adv_name);
}

Machine load_file(const fs::path& path, const std::string& spec) {
  InputOptions o;
  o.what = "machine file (.toml or Klipper printer.cfg)";
  o.max_bytes = kMaxMachineFileBytes;
  const std::string text = read_whole_text(spec, std::move(o));
  refuse_nul_bytes(text, spec);
  const std::string ext = lowercase(path.extension().string());
  if (ext == ".toml") return parse_toml_file(text, spec);
  if (ext == ".cfg" || ext == ".conf" || ext == ".ini") return parse_klipper_cfg(text, spec);
  // Marlin's own files, recognised by what they hold (docs/machine.md, "Marlin printers").
  if (looks_like_m503(text)) return parse_marlin_m503(text, spec);
  if (ext == ".h" || looks_like_marlin_configuration(text)) {
    return load_marlin_configuration(path, text, spec);
  }
  // No telling extension: TOML if it parses as TOML, else a Klipper config.
  bool is_toml = true;
  try {
    (void)toml::parse(text, spec);
  } catch (const toml::parse_error&) {
    is_toml = false;
  }
  if (is_toml || !looks_like_klipper(text)) return parse_toml_file(text, spec);
  return parse_klipper_cfg(text, spec);
}

const detail::EmbeddedPreset* find_preset(std::string_view name) {
  for (const auto& p : detail::embedded_presets()) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

Error unknown_preset(const std::string& name) {
  const std::vector<std::string> names = preset_names();
  return Error(fmt::format("unknown machine '{}'{} (presets: {}; or give the path of a .toml "
                           "file or a Klipper printer.cfg)",
                           name, detail::did_you_mean(name, names), fmt::join(names, ", ")));
}

}  // namespace

std::vector<std::string> preset_names() {
  std::vector<std::string> out;
  for (const auto& p : detail::embedded_presets()) out.emplace_back(p.name);
  std::sort(out.begin(), out.end());
  return out;
}

std::string_view preset_toml(const std::string& name) {
  const detail::EmbeddedPreset* p = find_preset(name);
  if (p == nullptr) throw unknown_preset(name);
  return p->text;
}

Machine preset(const std::string& name) {
  const detail::EmbeddedPreset* p = find_preset(name);
  if (p == nullptr) throw unknown_preset(name);
  return parse_machine_toml(p->text, fmt::format("configs/{}.toml", name));
}

Machine load_machine(const std::string& spec) {
  if (spec.empty()) return preset("default");
  // A bare name (no directory, no extension) is a preset; anything else is a path.
  const fs::path path(spec);
  const bool bare_name = !path.has_parent_path() && !path.has_extension();
  if (bare_name && find_preset(spec) != nullptr) return preset(spec);
  std::error_code ec;
  // Anything that exists is read as a file (a directory or an unreadable file is an error
  // naming it); "-" is standard input.
  if (spec == "-" || fs::exists(path, ec)) return load_file(path, spec);
  if (bare_name) throw unknown_preset(spec);
  throw Error(fmt::format("machine file '{}' does not exist (presets: {})", spec,
                          fmt::join(preset_names(), ", ")));
}

Machine load_machine(const std::string& spec, const std::vector<std::string>& overrides) {
  Machine m = load_machine(spec);
  for (const std::string& o : overrides) apply_override(m, o);
  validate(m);
  return m;
}

}  // namespace amctl::machine
