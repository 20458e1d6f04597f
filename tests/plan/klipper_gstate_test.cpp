// SAVE_/RESTORE_GCODE_STATE, [exclude_object] and an IDEX against Klipper's own batch mode
// (tests/reference/klipper/klipper_times_gstate.json, made by gstate_times.py with Klipper
// 84104bbb; README.md "G-code state, exclude_object and IDEX"), a print with start/end
// macros against the same, and the estimate's exclusion keys.
#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "amctl/core/error.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/report_json.hpp"

namespace amctl::plan {
namespace {

const std::string kDir = std::string(AMCTL_SOURCE_DIR) + "/tests/reference/klipper/";

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(KlipperHoming, G28EndsAtEachRailsPositionEndstop) {
  // homing.py: a homed axis ends at its rail's position_endstop (cartesian.py, corexy.py).
  // X homes to its maximum, 120: `G1 X100` is then a 20 mm move, not 100 mm. At 100 mm/s and
  // 3000 mm/s^2 it cruises (v^2 / a = 3.33 mm < 20 mm): T = d / v + v / a
  // = 0.2 + 0.0333 = 0.23333 s; from 0 it would be 1.0333 s.
  const std::string cfg =
      "[printer]\nkinematics: corexy\nmax_velocity: 300\nmax_accel: 3000\n"
      "[stepper_x]\nrotation_distance: 40\nmicrosteps: 16\nposition_endstop: 120\n"
      "position_max: 120\n"
      "[stepper_y]\nrotation_distance: 40\nmicrosteps: 16\nposition_endstop: 0\n"
      "position_max: 120\n";
  const auto m = machine::parse_klipper_cfg(cfg, "p.cfg");
  const auto r = estimate_text("G28\nG1 X100 F6000\n", "home", m);
  EXPECT_NEAR(r.total_time_s, 0.2 + 100.0 / 3000.0, 1e-9);
}

TEST(KlipperGcodeState, MatchesKlippersBatchMode) {
  const auto times = nlohmann::json::parse(slurp(kDir + "klipper_times_gstate.json"));
  int compared = 0;
  for (const auto& [key, c] : times.items()) {
    if (!c.is_object()) continue;  // klipper_commit
    const auto m = machine::load_machine(kDir + c.at("cfg").get<std::string>());
    const std::string text =
        c.at("setup").get<std::string>() + slurp(kDir + c.at("input").get<std::string>());
    const auto r = estimate_text(text, key, m);
    // Measured: within 2.3e-7 s on every case (the generic_cartesian IDEX: 5e-10 s; the IDEX
    // files with Klipper's 2 ms restart after
    // each SET_DUAL_CARRIAGE / ACTIVATE_EXTRUDER / RESTORE_DUAL_CARRIAGE_STATE flush) but the
    // macro print: +2.306 ms, amctl's stop for M109 that batch mode skips (tolerance_s 0.005).
    EXPECT_NEAR(r.total_time_s, c.at("motion_stock_s").get<double>(),
                c.at("tolerance_s").get<double>())
        << key;
    for (const auto& mr : r.macros)
      EXPECT_EQ(mr.skipped, 0u) << key << " " << mr.name << ": " << mr.skip_reason;
    EXPECT_FALSE(r.range_error.has_value()) << key;
    EXPECT_TRUE(r.unknown_commands.empty()) << key;
    ++compared;
  }
  EXPECT_EQ(compared, 6);
}

TEST(KlipperGcodeState, MirrorModeRangeStopsWhereKlipperStops) {
  // Klipper 84104bbb on syn_idex.gcode with line 37 "G1 X30 Y30 F6000" (now X65): "Move out of
  // range: 30.000 30.000 0.300" (the mirrored carriage would come within safe_distance).
  std::string text = slurp(kDir + "syn_idex.gcode");
  const std::string from = "G1 X65 Y30 F6000";
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "G1 X30 Y30 F6000");
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(at), '\n');
  const auto r =
      estimate_text("G28\n" + text, "idex", machine::load_machine(kDir + "idex_cartesian.cfg"));
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->line, static_cast<std::uint64_t>(line) + 1);  // + the G28 line
  EXPECT_EQ(r.range_error->axis, 'x');
  EXPECT_DOUBLE_EQ(r.range_error->position_mm, 30.0);
}

TEST(KlipperGcodeState, GenericCartesianDualCarriageRangeStopsWhereKlipperStops) {
  // Klipper 84104bbb on syn_gc_idex.gcode with "G1 X150 F6000" (carriage_u active, carriage_x
  // parked at 30, safe_distance 70) made "G1 X50 F6000": "Move out of range: 50.000 60.000
  // 0.300". amctl: carriage_u's range starts at 30 + 70 = 100.
  std::string text = slurp(kDir + "syn_gc_idex.gcode");
  const std::string from = "G1 X150 F6000";
  const auto at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "G1 X50 F6000");
  const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<long>(at), '\n');
  const auto r = estimate_text("G28\n" + text, "gc_idex",
                               machine::load_machine(kDir + "idex_generic_cartesian.cfg"));
  ASSERT_TRUE(r.range_error.has_value());
  EXPECT_EQ(r.range_error->line, static_cast<std::uint64_t>(line) + 1);  // + the G28 line
  EXPECT_EQ(r.range_error->axis, 'x');
  EXPECT_DOUBLE_EQ(r.range_error->position_mm, 50.0);
  EXPECT_DOUBLE_EQ(r.range_error->limit_mm, 100.0);
}

TEST(KlipperGcodeState, SetStepperCarriagesIsCheckedAsKlipperChecksIt) {
  // Klipper 84104bbb on idex_generic_cartesian.cfg (a = x+y, c = x-y) after G28:
  //  "STEPPER=a CARRIAGES=carriage_x-carriage_y": a = c, "Verify configured stepper(s) ...
  //  does not allow independent movements of all printer axes."; "STEPPER=a
  //  CARRIAGES=carriage_y+carriage_x": "SET_STEPPER_CARRIAGES cannot add or remove carriages
  //  that the stepper controls" (the same carriages in another order). Both stop the print.
  const auto m = machine::load_machine(kDir + "idex_generic_cartesian.cfg");
  auto refused = [&](const std::string& args) {
    try {
      (void)estimate_text("G28\nSET_STEPPER_CARRIAGES " + args + "\nG1 X10 F600\n", "s", m);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(refused("STEPPER=a CARRIAGES=carriage_x-carriage_y").find("independently"),
            std::string::npos);
  EXPECT_NE(refused("STEPPER=a CARRIAGES=carriage_y+carriage_x").find("cannot add or remove"),
            std::string::npos);
  EXPECT_NE(refused("STEPPER=e CARRIAGES=carriage_x").find("invalid STEPPER"), std::string::npos);
  EXPECT_EQ(refused("STEPPER=a CARRIAGES=carriage_x-carriage_y DISABLE_CHECKS=1"), "");
  // Swapping the belts, checked after the second change only (as syn_gc_idex.gcode ends,
  // timed there against batch mode); CARRIAGES is read in lower case as Klipper reads it.
  EXPECT_EQ(refused("STEPPER=a CARRIAGES=carriage_x-carriage_y DISABLE_CHECKS=1\n"
                    "SET_STEPPER_CARRIAGES STEPPER=c CARRIAGES=CARRIAGE_X+carriage_y"),
            "");
  // Elsewhere the command is unknown (not a generic_cartesian printer).
  const auto cart = machine::load_machine(kDir + "idex_cartesian.cfg");
  const auto r = estimate_text("G28\nSET_STEPPER_CARRIAGES STEPPER=x CARRIAGES=x\n", "s", cart);
  ASSERT_EQ(r.unknown_commands.size(), 1u);
  EXPECT_EQ(r.unknown_commands[0].name, "SET_STEPPER_CARRIAGES");
}

TEST(KlipperGcodeState, ExclusionReportsObjectsAndTheTimeSaved) {
  const auto with = machine::load_machine(kDir + "gstate_cartesian.cfg");
  auto without = with;
  without.exclude_object = false;  // the commands counted, every move made
  const std::string text = "G28\n" + slurp(kDir + "syn_exclude_object.gcode");
  const auto a = estimate_text(text, "x", with);
  const auto b = estimate_text(text, "x", without);
  ASSERT_EQ(a.excluded_objects.size(), 2u);
  EXPECT_EQ(a.excluded_objects[0].name, "PART_B");
  EXPECT_EQ(a.excluded_objects[1].name, "PART_C");
  // B's 7 moves in layer 1, C's 5 after EXCLUDE_OBJECT CURRENT=1 in layer 1 and its 3 in layer
  // 2 (B is back in layer 2; the reset at the end clears the rest).
  EXPECT_EQ(a.excluded_moves, 7u + 5u + 3u);
  ASSERT_TRUE(a.exclusion_time_saved_s.has_value());
  EXPECT_NEAR(*a.exclusion_time_saved_s, b.total_time_s - a.total_time_s, 1e-9);
  EXPECT_GT(*a.exclusion_time_saved_s, 1.0);
  EXPECT_TRUE(b.excluded_objects.empty());
  EXPECT_FALSE(b.exclusion_time_saved_s.has_value());
  // The JSON keys.
  const auto j = nlohmann::json::parse(to_json(a, with, 0.0).dump());
  EXPECT_EQ(j.at("excluded_objects").size(), 2u);
  EXPECT_EQ(j.at("excluded_moves").get<int>(), 15);
  EXPECT_NEAR(j.at("exclusion_time_saved_s").get<double>(), *a.exclusion_time_saved_s, 1e-12);
}

TEST(KlipperGcodeState, MacrosSeeExcludeObjectAsKlipperReportsIt) {
  // An M486-style macro of our own reading printer.exclude_object: "S-1" ends the current
  // object only when there is one (current_object is None outside an object).
  const std::string cfg =
      "[printer]\nkinematics: cartesian\nmax_velocity: 300\nmax_accel: 3000\n"
      "[extruder]\nrotation_distance: 33.5\nmicrosteps: 16\nnozzle_diameter: 0.4\n"
      "filament_diameter: 1.75\n"
      "[exclude_object]\n"
      "[gcode_macro M486]\ngcode:\n"
      "  {% if 'exclude_object' not in printer %}\n    M117 missing\n  {% endif %}\n"
      "  {% if 'S' in params and params.S == '-1' %}\n"
      "    {% if printer.exclude_object.current_object %}\n"
      "      EXCLUDE_OBJECT_END NAME={printer.exclude_object.current_object}\n"
      "    {% endif %}\n"
      "  {% elif 'S' in params %}\n    EXCLUDE_OBJECT_START NAME={params.S}\n  {% endif %}\n"
      "  {% if 'P' in params %}\n    EXCLUDE_OBJECT NAME={params.P}\n  {% endif %}\n";
  const auto m = machine::parse_klipper_cfg(cfg, "p.cfg");
  EXPECT_TRUE(m.exclude_object);
  std::string g = "M83\nM486 P1\nM486 S0\n";
  for (int i = 1; i <= 5; ++i) g += "G1 X" + std::to_string(i) + " E1 F600\n";  // learning moves
  g += "M486 S-1\nM486 S-1\nM486 S1\nG1 X50 E1\nG1 X60 E1\nM486 S-1\nM486 S0\nG1 X7 E1\n";
  const auto r = estimate_text(g, "m486", m);
  EXPECT_EQ(r.excluded_moves, 2u);
  EXPECT_EQ(r.moves, 6u);
  EXPECT_TRUE(r.unknown_commands.empty());
  for (const auto& mr : r.macros) EXPECT_EQ(mr.skipped, 0u) << mr.skip_reason;
}

}  // namespace
}  // namespace amctl::plan
