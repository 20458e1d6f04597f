#pragma once
// A Klipper printer.cfg as its kinematics read it: the sections (as the machine module's
// reader parsed them, klippy/configfile.py semantics) and typed access to an option with
// Klipper's checks (configfile.py ConfigWrapper: getfloat with minval, maxval, above, below;
// getint; getchoice), errors naming file:line:col, the section, the option, what was found
// and what was expected.
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/config_section.hpp"
#include "amctl/core/error.hpp"
#include "amctl/core/quantity.hpp"

namespace amctl::kinematics {

/// Klipper's bounds of a numeric option.
struct Limits {
  std::optional<double> minval = std::nullopt;
  std::optional<double> maxval = std::nullopt;
  std::optional<double> above = std::nullopt;
  std::optional<double> below = std::nullopt;
  /// amctl's physical range of the quantity (core/quantity.hpp), for a value other than 0.
  std::optional<PhysicalRange> physical = std::nullopt;
};

/// One section (possibly absent) of a printer.cfg.
class KlipperSection {
 public:
  KlipperSection(ConfigSection* s, std::string name, SourceLocation fallback)
      : s_(s), name_(std::move(name)), fallback_(std::move(fallback)) {}

  [[nodiscard]] bool present() const { return s_ != nullptr; }
  [[nodiscard]] bool has(std::string_view key) const;
  [[nodiscard]] const ConfigValue* raw(std::string_view key) const;

  /// The option as a number with Klipper's checks; unset when absent.
  [[nodiscard]] std::optional<double> get_float(std::string_view key, const Limits& lim = {}) const;
  /// The same with a default (recorded in the section's `defaults`, as Klipper's
  /// printer.configfile.settings shows it to macros).
  [[nodiscard]] double get_float(std::string_view key, double def, const Limits& lim = {}) const;
  /// Throws "option 'KEY' in section [NAME] must be specified" when absent.
  [[nodiscard]] double require_float(std::string_view key, const Limits& lim = {}) const;
  [[nodiscard]] std::optional<int> get_int(std::string_view key, const Limits& lim = {}) const;
  [[nodiscard]] int require_int(std::string_view key, const Limits& lim = {}) const;
  /// Klipper's choice options: the value, lower-cased, must be one of `choices`; `def` when
  /// the option is absent.
  [[nodiscard]] std::string get_choice(std::string_view key, std::string_view def,
                                       std::initializer_list<std::string_view> choices) const;
  [[nodiscard]] std::string require_text(std::string_view key) const;

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] ConfigSection* section() const { return s_; }
  /// Where the section starts (or the file, for an absent one).
  [[nodiscard]] const SourceLocation& where() const { return s_ ? s_->where : fallback_; }
  /// The "must be specified" error of `key`.
  [[nodiscard]] Error missing(std::string_view key) const;

 private:
  void check(const SourceLocation& where, std::string_view key, double x, const Limits& lim) const;
  ConfigSection* s_;
  std::string name_;
  SourceLocation fallback_;
};

/// The whole printer.cfg (includes resolved, SAVE_CONFIG merged).
class KlipperConfig {
 public:
  KlipperConfig(std::vector<ConfigSection>& sections, SourceLocation file)
      : sections_(sections), file_(std::move(file)) {}
  /// The section called `name` (absent: present() is false).
  [[nodiscard]] KlipperSection section(std::string_view name) const;
  [[nodiscard]] bool has(std::string_view name) const;
  [[nodiscard]] std::vector<ConfigSection>& sections() const { return sections_; }
  [[nodiscard]] const SourceLocation& file() const { return file_; }
  /// Where [printer] starts.
  [[nodiscard]] SourceLocation printer_where() const;

 private:
  std::vector<ConfigSection>& sections_;
  SourceLocation file_;
};

/// Klipper's stepper that a kinematics allocates: its section, drive-train key and unit.
struct KlipperStepper {
  std::string section;  ///< "stepper_x", "stepper my_stepper_u", ...
  std::string key;      ///< "x", "my_stepper_u", ...
  bool radians = false; ///< units_in_radians (gear_ratio required, no rotation_distance)
};

}  // namespace amctl::kinematics
