#pragma once
// One section of an INI-style configuration file (a Klipper printer.cfg) as written: option
// names and raw values with the place of each. The machine module reads these
// (machine/loader.hpp, parse_klipper_cfg) and keeps them in Machine::klipper_config; the
// macro module expands the [gcode_macro] ones and shows them all as printer.configfile.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"

namespace amctl {

struct ConfigValue {
  /// The value as written, trimmed; continuation lines joined with '\n' (each trimmed).
  std::string text;
  /// Where the value starts (the option line, column of the value).
  SourceLocation where;
  /// File line of each '\n'-separated piece of `text` (lines.front() == where.line).
  std::vector<std::uint64_t> lines;
  bool operator==(const ConfigValue& o) const {
    return text == o.text && where.file == o.where.file && where.line == o.where.line &&
           where.column == o.where.column && lines == o.lines;
  }
};

struct ConfigSection {
  std::string name;     ///< header text as written between '[' and ']', e.g. "gcode_macro START"
  SourceLocation where; ///< the header line (first appearance)
  std::map<std::string, ConfigValue> options;  ///< option names lower-cased, like configparser
  /// Options the file does not write that amctl's reader took a default for, as Python would
  /// print the value ("0.0"): Klipper's printer.configfile.settings holds such defaults too.
  std::map<std::string, std::string> defaults;

  [[nodiscard]] const ConfigValue* find(const std::string& key) const {
    auto it = options.find(key);
    return it == options.end() ? nullptr : &it->second;
  }
  bool operator==(const ConfigSection& o) const {
    return name == o.name && where.file == o.where.file && where.line == o.where.line &&
           options == o.options && defaults == o.defaults;
  }
};

}  // namespace amctl
