// [gcode_macro] expansion through the interpreter: parameters parsed as klippy/gcode.py does,
// the printer fields, variables and SET_GCODE_VARIABLE, rename_existing, recursion refused as
// Klipper refuses it, and every skip reported with the macro's file and line. Expected values
// are worked out by hand from Klipper's code (gcode.py, extras/gcode_macro.py).
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "amctl/core/error.hpp"
#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/macro/expander.hpp"

namespace amctl::macro {
namespace {

/// A [gcode_macro] section whose options start at `first_line` of printer.cfg, one line each;
/// the gcode option's continuation lines follow it.
ConfigSection macro_section(const std::string& name, const std::string& gcode,
                            std::vector<std::pair<std::string, std::string>> extra = {},
                            std::uint64_t first_line = 10) {
  ConfigSection s;
  s.name = "gcode_macro " + name;
  s.where = SourceLocation{"printer.cfg", first_line, 1};
  std::uint64_t line = first_line + 1;
  for (auto& [k, v] : extra) {
    s.options[k] = ConfigValue{v, SourceLocation{"printer.cfg", line, 1}, {line}};
    ++line;
  }
  ConfigValue g{gcode, SourceLocation{"printer.cfg", line, 7}, {}};
  for (std::size_t i = 0, n = std::count(gcode.begin(), gcode.end(), '\n') + 1; i < n; ++i) {
    g.lines.push_back(line + i);
  }
  s.options["gcode"] = g;
  return s;
}

struct Recorder final : gcode::EventSink {
  std::vector<gcode::MoveRequest> moves;
  std::vector<gcode::HeaterCommand> heaters;
  std::vector<std::string> untimed;
  void on_move(const gcode::MoveRequest& m) override { moves.push_back(m); }
  void on_heater(const gcode::HeaterCommand& h) override { heaters.push_back(h); }
  void on_untimed(std::string_view n, std::uint64_t) override { untimed.emplace_back(n); }
};

struct Outcome {
  Recorder sink;
  std::vector<MacroReport> reports;
  std::vector<gcode::UnknownCommand> unknown;
};

Outcome run(const std::vector<ConfigSection>& cfg, const std::string& gcode_text,
        ToolheadInfo th = {}, RenderLimits limits = {}) {
  MacroExpander x(cfg, th, limits);
  gcode::Interpreter interp(gcode::InterpreterOptions{}, "t.gcode");
  interp.set_expander(&x);
  gcode::LineReader reader(gcode_text, "t.gcode");
  Outcome r;
  interp.run(reader, r.sink);
  r.reports = x.reports();
  r.unknown = interp.unknown_commands();
  return r;
}

void load(const std::vector<ConfigSection>& cfg) { MacroExpander x(cfg, ToolheadInfo{}); }

TEST(KlipperParams, ExtendedCommandsSplitLikeShlexWithUpperCaseKeys) {
  Dict d;
  ASSERT_TRUE(extended_params("bed_temp=60 EXTRUDER=\"2 10\" material='PLA' ; comment X=1", d));
  EXPECT_EQ(d.find("BED_TEMP")->text(), "60");
  EXPECT_EQ(d.find("EXTRUDER")->text(), "2 10");
  EXPECT_EQ(d.find("MATERIAL")->text(), "PLA");  // quotes removed, value case kept
  EXPECT_EQ(d.find("X"), nullptr);                // after the comment
  Dict bad;
  EXPECT_FALSE(extended_params("BED=60 oops", bad));  // a word without '=': Malformed command
  EXPECT_FALSE(extended_params("A='open", bad));      // no closing quotation
}

TEST(KlipperParams, WordCommandsSplitAtRunsOfLetters) {
  // gcode.py: re.split('([A-Z_]+|[A-Z*])', line.upper()) -> key, value pairs; the command
  // letter is a key too, and adjacent letters form one key.
  const Dict d = word_params("m109 s215.5 T0 ; wait");
  EXPECT_EQ(d.find("M")->text(), "109");
  EXPECT_EQ(d.find("S")->text(), "215.5");
  EXPECT_EQ(d.find("T")->text(), "0");
  const Dict g = word_params("G28 XY");
  EXPECT_EQ(g.find("XY")->text(), "");
  EXPECT_EQ(g.find("X"), nullptr);
}

TEST(KlipperParams, RawParamsAreTheTextAfterTheCommandWord) {
  EXPECT_EQ(raw_params("  PRINT_START BED=60 ; go", "PRINT_START"), "BED=60 ; go");
  EXPECT_EQ(raw_params("N12 M600 X5*42", "M600"), "X5");
  EXPECT_EQ(raw_params("PRINT_END", "PRINT_END"), "");
}

TEST(MacroExpander, AMacroRunsItsLinesWithParamsAtTheCallingLine) {
  const auto cfg = {macro_section("start", "M190 S{params.BED|default(55)}\n"
                                           "M109 S{params.EXTRUDER|float}\n"
                                           "G1 X{params.X|int + 5} F6000")};
  const Outcome r = run(cfg, "G1 X1 F3000\nSTART extruder=215 x=10 bed=60\n");
  ASSERT_EQ(r.sink.heaters.size(), 2u);
  EXPECT_DOUBLE_EQ(r.sink.heaters[0].target_c, 60.0);
  EXPECT_DOUBLE_EQ(r.sink.heaters[1].target_c, 215.0);
  EXPECT_EQ(r.sink.heaters[1].line, 2u);
  ASSERT_EQ(r.sink.moves.size(), 2u);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].end_mm[0], 15.0);
  EXPECT_EQ(r.sink.moves[1].line, 2u);  // expanded lines point at the call
  ASSERT_EQ(r.reports.size(), 1u);
  EXPECT_EQ(r.reports[0].name, "START");
  EXPECT_EQ(r.reports[0].expanded, 1u);
  EXPECT_EQ(r.reports[0].first_line, 2u);
  EXPECT_TRUE(r.unknown.empty());
}

TEST(MacroExpander, PrinterFieldsShowTheStateAtTheCall) {
  ToolheadInfo th;
  th.max_velocity_mm_s = 300;
  th.axis_minimum_mm = std::array<double, 3>{0, -5, 0};
  th.axis_maximum_mm = std::array<double, 3>{235, 230, 250};
  const auto cfg = {macro_section(
      "park",
      "{% if 'x' not in printer.toolhead.homed_axes %}G28{% endif %}\n"
      "G1 X{printer.toolhead.axis_maximum.x - 5} Y{printer.toolhead.axis_minimum.y + 10}"
      " Z{printer.toolhead.position.z + 10} F{printer.toolhead.max_velocity * 60}")};
  // G91 moves: the macro reads the position after them; G28 runs only when X is not homed.
  const Outcome r = run(cfg, "G28\nG1 Z2 F600\nPARK\n", th);
  EXPECT_EQ(r.sink.untimed.size(), 1u);  // the file's G28 only
  ASSERT_EQ(r.sink.moves.size(), 2u);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].end_mm[0], 230.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].end_mm[1], 5.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].end_mm[2], 12.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].speed_mm_s, 300.0);
  const Outcome cold = run(cfg, "PARK\n", th);
  EXPECT_EQ(cold.sink.untimed.size(), 1u);  // the macro's G28
}

TEST(MacroExpander, VariablesAndSetGcodeVariable) {
  const auto cfg = {macro_section("purge", "G1 X{length} E{length / 10} F1200",
                                  {{"variable_length", "40"}}),
                    macro_section("use", "G1 Y{printer['gcode_macro purge'].length}", {}, 30)};
  const Outcome r = run(cfg, "G92 E0\nPURGE\nSET_GCODE_VARIABLE MACRO=purge VARIABLE=length VALUE=80\n"
                         "PURGE\nUSE\n");
  ASSERT_EQ(r.sink.moves.size(), 3u);
  EXPECT_DOUBLE_EQ(r.sink.moves[0].end_mm[0], 40.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[0].end_mm[3], 4.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[1].end_mm[0], 80.0);
  EXPECT_DOUBLE_EQ(r.sink.moves[2].end_mm[1], 80.0);
  // Unknown variable: Klipper stops with an error; amctl reports it and goes on.
  const Outcome bad = run(cfg, "SET_GCODE_VARIABLE MACRO=purge VARIABLE=speed VALUE=1\n");
  ASSERT_EQ(bad.reports.size(), 1u);
  EXPECT_EQ(bad.reports[0].name, "SET_GCODE_VARIABLE");
  EXPECT_NE(bad.reports[0].skip_reason.find("Unknown gcode_macro variable 'speed'"), std::string::npos);
}

TEST(MacroExpander, RenameExistingKeepsTheBuiltInUnderItsNewName) {
  const auto cfg = {macro_section("M109", "M99109 S{params.S|float + 5}",
                                  {{"rename_existing", "M99109"}})};
  const Outcome r = run(cfg, "M109 S200\n");
  ASSERT_EQ(r.sink.heaters.size(), 1u);
  EXPECT_DOUBLE_EQ(r.sink.heaters[0].target_c, 205.0);
  EXPECT_TRUE(r.sink.heaters[0].wait);
  EXPECT_TRUE(r.unknown.empty());
  EXPECT_THROW(load({macro_section("M109", "G4", {{"rename_existing", "BASE_M109"}})}),
               Error);
}

TEST(MacroExpander, RecursionIsRefusedAndReportedOnce) {
  const auto cfg = {macro_section("loop_a", "G1 X1\nLOOP_B"), macro_section("loop_b", "G1 X2\nLOOP_A", {}, 20)};
  const Outcome r = run(cfg, "LOOP_A\nloop_a\n");
  // A -> B -> A (refused), twice: moves to X1, X2, X1, X2.
  ASSERT_EQ(r.sink.moves.size(), 4u);
  ASSERT_EQ(r.reports.size(), 2u);
  EXPECT_EQ(r.reports[0].name, "LOOP_A");
  EXPECT_EQ(r.reports[0].calls, 4u);
  EXPECT_EQ(r.reports[0].expanded, 2u);
  EXPECT_EQ(r.reports[0].skipped, 2u);
  EXPECT_EQ(r.reports[0].skip_reason, "Macro LOOP_A called recursively (Klipper refuses it)");
}

TEST(MacroExpander, WhatAmctlCannotEvaluateIsSkippedWithTheMacrosLine) {
  const auto cfg = {macro_section("probe_it", "G1 X1\nG1 Z{printer.probe.last_z_result}"),
                    macro_section("weird", "G1 X1\n{% macro m() %}{% endmacro %}", {}, 20),
                    macro_section("stop", "{action_raise_error('no filament')}", {}, 30)};
  const Outcome r = run(cfg, "PROBE_IT\nWEIRD\nSTOP\nPROBE_IT\n");
  EXPECT_TRUE(r.sink.moves.empty());  // a skipped call runs none of its lines
  ASSERT_EQ(r.reports.size(), 3u);
  EXPECT_EQ(r.reports[0].skipped, 2u);
  EXPECT_EQ(r.reports[0].first_skipped_line, 1u);
  // gcode: starts at printer.cfg line 11; its second line is line 12.
  EXPECT_EQ(r.reports[0].skip_reason,
            "at printer.cfg:12: 'printer.probe' is undefined (a printer object or field amctl "
            "does not model)");
  EXPECT_EQ(r.reports[1].skip_reason,
            "amctl cannot read the template at printer.cfg:22: statement '{% macro %}' is not "
            "supported");
  EXPECT_NE(r.reports[2].skip_reason.find("action_raise_error(\"no filament\")"), std::string::npos);
}

TEST(MacroExpander, ABadLineAMacroWritesIsAnErrorAtTheCallNamingTheMacro) {
  const auto cfg = {macro_section("move", "G4 P0\nG1 X{params.X|default('')} F6000")};
  try {
    (void)run(cfg, "G28\nMOVE\n");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "t.gcode:2: expected a number after 'X' (is the file truncated?) (in "
                           "the lines of macro MOVE: 'G1 X F6000')");
  }
}

TEST(MacroExpander, WhatKlipperRefusesAtStartIsAnError) {
  ConfigSection spaced = macro_section("a b", "G4");
  EXPECT_THROW(load({spaced}), Error);
  ConfigSection no_gcode = macro_section("x", "G4");
  no_gcode.options.erase("gcode");
  EXPECT_THROW(load({no_gcode}), Error);
  EXPECT_THROW(load({macro_section("x", "G4"), macro_section("X", "G4")}), Error);
}

// Each macro calls the next twice, 40 deep: 2^40 calls. The work of one call with the
// macros it calls is bounded: an amctl::Error at the macro's printer.cfg line naming the
// bound, in well under a second, not a run that never ends.
TEST(MacroExpander, AFanOutOfCallsIsStoppedByTheWorkBoundOfOneExpansion) {
  std::vector<ConfigSection> cfg;
  for (int i = 0; i < 40; ++i) {
    cfg.push_back(macro_section("fan_" + std::to_string(i),
                                "FAN_" + std::to_string(i + 1) + "\nFAN_" + std::to_string(i + 1), {},
                                10 + 10 * static_cast<std::uint64_t>(i)));
  }
  cfg.push_back(macro_section("fan_40", "G4 P0", {}, 500));
  // The bound lowered to 5000 calls to keep the test fast; the default (10^5) stops the same
  // way (the row macro_calls_fan_out of tests/cli/bad_inputs.py).
  RenderLimits lim;
  lim.max_calls_per_expansion = 5000;
  try {
    (void)run(cfg, "G28\nFAN_0\n", {}, lim);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, "printer.cfg");
    EXPECT_NE(std::string(e.what()).find("expansion limit: the call at G-code line 2 makes more than 5000 "
                                         "macro calls"),
              std::string::npos)
        << e.what();
  }
  // A fan-out within the bound runs: 2^10 leaves.
  std::vector<ConfigSection> small;
  for (int i = 0; i < 10; ++i) {
    small.push_back(macro_section("leaf_" + std::to_string(i),
                                  "LEAF_" + std::to_string(i + 1) + "\nLEAF_" + std::to_string(i + 1), {},
                                  10 + 10 * static_cast<std::uint64_t>(i)));
  }
  small.push_back(macro_section("leaf_10", "G4 P0", {}, 500));
  EXPECT_NO_THROW((void)run(small, "LEAF_0\n", {}, lim));
}

// A bound of one render is an error of the run at the macro's line (not a skipped call):
// Klipper would not get through it either.
TEST(MacroExpander, ARenderLimitIsAnErrorAtTheMacrosLine) {
  const auto cfg = {macro_section("boom", "G4 P0\n{% set ns = namespace(s='x') %}{% for i in range(64) %}"
                                          "{% set ns.s = ns.s ~ ns.s %}{% endfor %}")};
  try {
    (void)run(cfg, "G28\nBOOM\n");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.where().file, "printer.cfg");
    EXPECT_EQ(e.where().line, 12u);  // the template's second line
    EXPECT_NE(std::string(e.what()).find("macro BOOM (called at G-code line 2)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("limit"), std::string::npos) << e.what();
  }
  // Nesting beyond the bound fails when the config is read, at the macro.
  EXPECT_THROW(load({macro_section("deep", "{ 1" + std::string(3000, '+') + " }")}), Error);
  std::string chain = "{ 1";
  for (int i = 0; i < 1000; ++i) chain += "|abs";
  try {
    load({macro_section("deep", "G4\n" + chain + " }")});
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.where().line, 12u);
    EXPECT_NE(std::string(e.what()).find("nested more than 200 deep"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amctl::macro
