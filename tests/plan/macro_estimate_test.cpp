// A print whose start and end G-code are Klipper macros (tests/reference/macro/printer.cfg,
// macros.cfg: home, heat, heat-soak, park, purge line, a renamed M109, park at the end) is
// timed as the same print with the macros expanded by the real Jinja2
// (tests/reference/macro/expand_reference.py wrote print_expanded.gcode) on the printer
// without macros.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"

namespace amctl::plan {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/macro/";

TEST(MacroEstimate, MacrosAreTimedAsTheirJinja2Expansion) {
  const auto with_macros = machine::load_machine(kDir + "printer.cfg");
  const auto without = machine::load_machine(kDir + "printer_base.cfg");
  const EstimateReport a = estimate_file(kDir + "print.gcode", with_macros);
  const EstimateReport b = estimate_file(kDir + "print_expanded.gcode", without);
  EXPECT_NEAR(a.total_time_s, b.total_time_s, 1e-9);
  EXPECT_EQ(a.moves, b.moves);
  EXPECT_NEAR(a.filament_mm, b.filament_mm, 1e-9);
  // SOAK=1: one G4 P60000; M84: Klipper's step-generation restart (2 x 1 ms after the last
  // move) and 2 x 0.1 s (stepper_enable.py; measured in batch mode: KlipperGcodeState.MatchesKlippersBatchMode).
  EXPECT_NEAR(a.dwell_time_s, 60.0 + 0.002 + 0.2, 1e-9);
  EXPECT_EQ(a.heater_waits.size(), b.heater_waits.size());
  EXPECT_TRUE(a.unknown_commands.empty());
  ASSERT_EQ(a.macros.size(), 4u);
  EXPECT_EQ(a.macros[0].name, "PRINT_START");
  EXPECT_EQ(a.macros[0].description, "Home, heat, heat-soak and purge");
  EXPECT_EQ(a.macros[1].name, "M109");
  EXPECT_EQ(a.macros[2].name, "_PURGE_LINE");
  EXPECT_EQ(a.macros[3].name, "PRINT_END");
  for (const auto& m : a.macros) {
    EXPECT_EQ(m.expanded, 1u) << m.name;
    EXPECT_EQ(m.skipped, 0u) << m.name << ": " << m.skip_reason;
  }
  EXPECT_EQ(a.macros[2].first_line, 2u);  // nested calls count at the file's calling line
  // Without the macros the calls are unknown commands and the print is shorter.
  const EstimateReport c = estimate_file(kDir + "print.gcode", without);
  ASSERT_EQ(c.unknown_commands.size(), 2u);
  EXPECT_LT(c.total_time_s, a.total_time_s - 60.0);
}

TEST(MacroEstimate, SettingsHoldTheDefaultsTheReaderTook) {
  // configfile.py: printer.configfile.settings holds every option a module read, defaults
  // included; printer.configfile.config only what the file writes. [stepper_x] without
  // position_min: settings has 0.0 (stepper.py's default), config nothing. Klipper's own
  // generic_cartesian_iqex.test parks with such a value.
  const std::string cfg =
      "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_max: 200\n"
      "position_endstop: 0\n"
      "[gcode_macro PARK]\ngcode:\n"
      "  G1 X{printer.configfile.settings.stepper_x.position_min + 5} F6000\n"
      "  G1 X{printer.configfile.config.stepper_x.position_min|default(7)}\n";
  const auto m = machine::parse_klipper_cfg(cfg, "p.cfg");
  // From X0: to 5.0 (0.0 + 5), then to 7 (config has no position_min, so the default(7)).
  // Collinear, the two moves join at full speed: one 7 mm trapezoid at 100 mm/s and
  // 3000 mm/s^2 (v^2/a = 3.33 mm < 7 mm), T = d/v + v/a. Without the default in settings the
  // first expression is undefined and the macro is skipped (no move); had config held it, the
  // second move would go back to 0.
  const EstimateReport r = estimate_text("G28\nPARK\n", "park", m);
  EXPECT_EQ(r.moves, 2u);
  EXPECT_TRUE(r.unknown_commands.empty());
  EXPECT_NEAR(r.total_time_s, 7.0 / 100.0 + 100.0 / 3000.0, 1e-9);
}

TEST(MacroEstimate, FilesWithoutMacroCallsAreTimedAsBefore) {
  const auto with_macros = machine::load_machine(kDir + "printer.cfg");
  const auto without = machine::load_machine(kDir + "printer_base.cfg");
  const std::string g = "G28\nG1 X10 Y10 F6000\nG2 X20 Y10 I5 J0\nG1 Z1\nM109 S200\n";
  const EstimateReport a = estimate_text(g, "t.gcode", with_macros);
  const EstimateReport b = estimate_text(g, "t.gcode", without);
  EXPECT_EQ(a.total_time_s, b.total_time_s);  // the M109 macro only adds a message
  EXPECT_EQ(a.moves, b.moves);
}

}  // namespace
}  // namespace amctl::plan
