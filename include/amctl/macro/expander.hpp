#pragma once
// Klipper's [gcode_macro NAME] sections expanded where the G-code calls them, as
// klippy/extras/gcode_macro.py does: the call's parameters become `params` (keys upper-cased;
// KEY=VALUE with shell-style quoting for extended names, letter words for G/M names) and
// `rawparams`, the macro's `variable_*` options are names of their own, `printer` shows what
// amctl knows (toolhead, gcode_move, heaters, configfile, every macro's variables), the
// template is rendered once per call and its lines run in place of the call. SET_GCODE_VARIABLE
// changes a variable; `rename_existing` keeps the built-in command under a new name. A macro
// calling itself, directly or not, is refused as Klipper refuses it. A call amctl cannot
// evaluate is skipped and reported with the reason, never an error of the run; a template or a
// call beyond amctl's bounds (template.hpp: kMaxTemplateBytes, kMaxNesting, RenderLimits, the
// work of one call with the macros it calls) is an amctl::Error at the macro's file:line naming
// the bound (docs/macros.md, "Limits").
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "amctl/core/config_section.hpp"
#include "amctl/gcode/expander.hpp"
#include "amctl/macro/template.hpp"
#include "amctl/macro/value.hpp"

namespace amctl::macro {

/// What the printer reports that the G-code cannot change (Klipper printer.toolhead).
struct ToolheadInfo {
  double max_velocity_mm_s = 0.0;
  double max_accel_mm_s2 = 0.0;
  double square_corner_velocity_mm_s = 0.0;
  double minimum_cruise_ratio = 0.0;
  /// [stepper_x/y/z] position_min / position_max; unset: axis_minimum/maximum are undefined.
  std::optional<std::array<double, 3>> axis_minimum_mm, axis_maximum_mm;
};

/// One macro and what became of its calls.
struct MacroReport {
  std::string name;             ///< as Klipper registers it (upper case)
  std::string description;      ///< its `description:` ("G-Code macro" when absent, as Klipper)
  SourceLocation defined_at;    ///< the [gcode_macro] section header
  std::uint64_t calls = 0;
  std::uint64_t expanded = 0;   ///< calls whose lines ran
  std::uint64_t skipped = 0;    ///< calls skipped (reason below)
  std::uint64_t first_line = 0;          ///< G-code line of the first call
  std::string skip_reason;               ///< why the first skipped call was skipped ("" if none)
  std::uint64_t first_skipped_line = 0;  ///< G-code line of that call
};

class MacroExpander final : public gcode::CommandExpander {
 public:
  /// Reads the [gcode_macro] sections of `config` (and shows every section as
  /// printer.configfile). Throws amctl::Error at the section for what Klipper refuses at start
  /// (a name with spaces, no `gcode:` option, two macros of one name, a rename between a G/M
  /// word and an extended name); what amctl only cannot read (a template construct, a literal)
  /// is kept as the reason to skip that macro's calls.
  MacroExpander(std::span<const ConfigSection> config, const ToolheadInfo& toolhead,
                RenderLimits limits = {});

  /// No [gcode_macro] section in the config.
  [[nodiscard]] bool empty() const { return macros_.empty(); }

  gcode::Expansion expand(const gcode::Command& cmd, std::string_view line, std::uint64_t line_no,
                          const gcode::InterpreterState& state) override;
  void end_script(std::uint32_t id) override;
  [[nodiscard]] bool expands_moves() const override { return expands_moves_; }

  /// Every macro called (and SET_GCODE_VARIABLE when it failed), in order of first call.
  [[nodiscard]] std::vector<MacroReport> reports() const;

 private:
  struct Macro {
    std::string section;   // "gcode_macro Name" as written (printer["gcode_macro Name"])
    std::string written;   // NAME as written (SET_GCODE_VARIABLE MACRO=NAME)
    std::string name;      // upper case alias
    SourceLocation gcode_at;
    std::vector<std::uint64_t> gcode_lines;  // file line of each template line
    std::optional<Template> tmpl;
    std::string error;      // why calls are skipped ("" = none)
    Dict variables;
    bool in_script = false;
    MacroReport report;
  };

  gcode::Expansion skip(std::size_t macro, std::uint64_t line_no, std::string reason);
  gcode::Expansion set_gcode_variable(std::string_view rawparams, std::uint64_t line_no);
  [[nodiscard]] Value printer_object(const gcode::InterpreterState& state) const;
  /// "file:line" of template line `line` of macro `m` (0: the gcode: option).
  [[nodiscard]] std::string where(const Macro& m, std::uint32_t line) const;
  [[nodiscard]] SourceLocation location(const Macro& m, std::uint32_t line) const;

  std::vector<Macro> macros_;
  std::map<std::string, std::size_t, std::less<>> by_name_;
  std::map<std::string, std::string, std::less<>> renamed_;  // rename_existing -> built-in
  std::optional<MacroReport> set_variable_report_;
  Value configfile_;
  std::vector<std::string> heaters_;  // "extruder", "heater_bed" when configured
  ToolheadInfo toolhead_;
  RenderLimits limits_;
  std::vector<std::size_t> call_order_;
  std::size_t depth_ = 0;
  std::uint64_t tree_calls_ = 0;      // renders since the last top-level call
  std::uint64_t tree_bytes_ = 0;      // G-code text they produced
  std::uint64_t tree_root_line_ = 0;  // that call's G-code line
  bool expands_moves_ = false;
};

/// Klipper's parameters of an extended command (gcode.py _get_extended_params): the raw
/// parameter text split like Python's shlex (posix, whitespace_split, '#' and ';' comments),
/// each word KEY=VALUE with KEY upper-cased. False (a "Malformed command") if a word has no '='.
bool extended_params(std::string_view rawparams, Dict& out);

/// Klipper's parameters of a G/M word command (gcode.py _process_commands): the upper-cased
/// line split at runs of letters, each run a key and the text after it (trimmed) its value.
Dict word_params(std::string_view line);

/// The parameter text after the command word (gcode.py get_raw_command_parameters).
std::string raw_params(std::string_view line, std::string_view command);

}  // namespace amctl::macro
