// Marlin machines from M503 output and from Configuration.h: every value checked against the
// text it was read from (the reports below are in the forms real terminals show: Marlin 2.x
// with junction deviation through OctoPrint, Marlin 1.1 with classic jerk as Pronterface shows
// it, Prusa's firmware), recognised by content by load_machine, and the errors of bad ones.
#include <gtest/gtest.h>

#include "amctl/machine/json.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/machine/marlin.hpp"
#include "test_util.hpp"

namespace amctl::machine {
namespace {

using test::error_of;
using test::TempDir;

// Marlin 2.x (junction deviation) as OctoPrint's terminal shows M503.
const char* const kOctoPrintJd = R"(Send: M503
Recv: echo:; Linear Units:
Recv: echo:  G21 ;
Recv:  (mm)
Recv: echo:; Filament settings (Disabled):
Recv: echo:  M200 S0 D1.75
Recv: echo:; Steps per unit:
Recv: echo:  M92 X80.00 Y80.00 Z800.00 E130.00
Recv: echo:; Max feedrates (units/s):
Recv: echo:  M203 X500.00 Y500.00 Z5.00 E25.00
Recv: echo:; Max Acceleration (units/s2):
Recv: echo:  M201 X500.00 Y500.00 Z100.00 E10000.00
Recv: echo:; Acceleration (units/s2) (P<print-accel> R<retract-accel> T<travel-accel>):
Recv: echo:  M204 P500.00 R700.00 T1000.00
Recv: echo:; Advanced (B<min_segment_time_us> S<min_feedrate> T<min_travel_feedrate> J<junc_dev>):
Recv: echo:  M205 B20000.00 S0.00 T0.00 J0.01
Recv: echo:; Home offset:
Recv: echo:  M206 X0.00 Y0.00 Z0.00
Recv: echo:; Z-Probe Offset:
Recv: echo:  M851 X-44.00 Y-5.00 Z-0.40 ; (mm)
Recv: echo:; Linear Advance:
Recv: echo:  M900 K0.05
Recv: echo:; Input Shaping:
Recv: echo:  M593 X F41.20 D0.12
Recv: echo:  M593 Y F37.50 D0.10
Recv: ok
)";

// Marlin 1.1 (classic jerk) as Pronterface shows it.
const char* const kPronterfaceJerk = R"(>>> m503
SENDING:M503
echo:Steps per unit:
echo: M92 X80.00 Y80.00 Z400.00 E93.00
echo:Maximum feedrates (units/s):
echo:  M203 X500.00 Y500.00 Z5.00 E25.00
echo:Maximum Acceleration (units/s2):
echo:  M201 X500 Y500 Z100 E5000
echo:Acceleration (units/s2): P<print_accel> R<retract_accel> T<travel_accel>
echo:  M204 P500.00 R1000.00 T1000.00
echo:Advanced: B<min_segment_time_us> S<min_feedrate> T<min_travel_feedrate> X<max_x_jerk> Y<max_y_jerk> Z<max_z_jerk> E<max_e_jerk>
echo:  M205 B20000.00 S0.00 T0.00 X10.00 Y10.00 Z0.30 E5.00
echo:PID settings:
echo:  M301 P28.72 I2.62 D78.81
echo:  M413 S1
ok
)";

// Prusa's firmware (MK3S): headings without ';', B in microseconds though labelled ms.
const char* const kPrusa = R"(echo:Steps per unit:
echo:  M92 X100.00 Y100.00 Z400.00 E280.00
echo:Maximum feedrates (mm/s):
echo:  M203 X200.00 Y200.00 Z12.00 E120.00
echo:Maximum acceleration (mm/s2):
echo:  M201 X1000 Y1000 Z200 E5000
echo:Acceleration: P=print, R=retract, T=travel
echo:  M204 P1250.00 R1250.00 T1250.00
echo:Advanced variables: S=Min feedrate (mm/s), T=Min travel feedrate (mm/s), B=minimum segment time (ms), X=maximum XY jerk (mm/s),  Z=maximum Z jerk (mm/s),  E=maximum E jerk (mm/s)
echo:  M205 S0.00 T0.00 B20000 X10.00 Y10.00 Z0.40 E4.50
)";

TEST(MarlinM503, OctoPrintLogWithJunctionDeviation) {
  ASSERT_TRUE(looks_like_m503(kOctoPrintJd));
  const Machine m = parse_marlin_m503(kOctoPrintJd, "dir/ender5.txt");
  EXPECT_EQ(m.name, "ender5");
  EXPECT_EQ(m.firmware, Firmware::marlin);
  EXPECT_EQ(m.junction, JunctionPolicy::junction_deviation);
  EXPECT_DOUBLE_EQ(m.junction_deviation_mm, 0.01);
  EXPECT_EQ(m.max_feedrate_mm_s, (std::array<double, 4>{500, 500, 5, 25}));
  EXPECT_EQ(m.max_axis_accel_mm_s2, (std::array<double, 4>{500, 500, 100, 10000}));
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 500);
  EXPECT_DOUBLE_EQ(m.retract_accel_mm_s2, 700);
  EXPECT_DOUBLE_EQ(m.travel_accel_mm_s2, 1000);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 500);      // printer.max_accel = M204 P
  EXPECT_DOUBLE_EQ(m.max_velocity_mm_s, 500);    // the XY feedrate limit
  EXPECT_DOUBLE_EQ(m.min_segment_time_s, 0.02);  // B20000 us
  EXPECT_DOUBLE_EQ(m.extruder.filament_diameter_mm, 1.75);
  // Steps/mm are exact whatever the microsteps: 200 * 16 / rotation_distance.
  EXPECT_DOUBLE_EQ(m.steppers.at("x").steps_per_mm(), 80.0);
  EXPECT_DOUBLE_EQ(m.steppers.at("z").steps_per_mm(), 800.0);
  EXPECT_DOUBLE_EQ(m.steppers.at("e").steps_per_mm(), 130.0);
  EXPECT_EQ(m.input_shaper.shaper_type_x, "zv");
  EXPECT_DOUBLE_EQ(m.input_shaper.shaper_freq_x_hz, 41.2);
  EXPECT_DOUBLE_EQ(m.input_shaper.damping_ratio_x, 0.12);
  EXPECT_DOUBLE_EQ(m.input_shaper.shaper_freq_y_hz, 37.5);
  EXPECT_DOUBLE_EQ(m.input_shaper.damping_ratio_y, 0.10);
}

TEST(MarlinM503, PronterfaceWithClassicJerk) {
  const Machine m = parse_marlin_m503(kPronterfaceJerk, "m503.log");
  EXPECT_EQ(m.junction, JunctionPolicy::classic_jerk);
  EXPECT_EQ(m.jerk_mm_s, (std::array<double, 4>{10, 10, 0.3, 5}));
  EXPECT_EQ(m.max_axis_accel_mm_s2, (std::array<double, 4>{500, 500, 100, 5000}));
  EXPECT_DOUBLE_EQ(m.retract_accel_mm_s2, 1000);
  EXPECT_DOUBLE_EQ(m.steppers.at("e").steps_per_mm(), 93.0);
}

TEST(MarlinM503, PrusaFirmwareReportMatchesThePrusaPreset) {
  const Machine m = parse_marlin_m503(kPrusa, "mk3s.txt");
  const Machine p = preset("prusa-mk3s");
  EXPECT_EQ(m.junction, p.junction);
  EXPECT_EQ(m.max_feedrate_mm_s, p.max_feedrate_mm_s);
  EXPECT_EQ(m.max_axis_accel_mm_s2, p.max_axis_accel_mm_s2);
  EXPECT_EQ(m.jerk_mm_s, p.jerk_mm_s);
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, p.print_accel_mm_s2);
  EXPECT_DOUBLE_EQ(m.min_segment_time_s, p.min_segment_time_s);
  for (const char* s : {"x", "y", "z", "e"}) {
    EXPECT_DOUBLE_EQ(m.steppers.at(s).steps_per_mm(), p.steppers.at(s).steps_per_mm()) << s;
  }
}

TEST(MarlinM503, OlderFirmwareM204SIsPrintAndTravel) {
  const std::string text = "echo:  M203 X300 Y300 Z5 E25\necho:  M201 X3000 Y3000 Z100 E5000\n"
                           "echo:  M204 S1500.00 T3000.00\necho:  M205 X8 Y8 Z0.4 E5\n";
  const Machine m = parse_marlin_m503(text, "old.txt");
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 1500);
  EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 1500);
  EXPECT_DOUBLE_EQ(m.travel_accel_mm_s2, 3000);
}

TEST(MarlinM503, CommandNumbersOfManyDigitsAreIgnoredNotOverflows) {
  // fuzz_marlin (UBSan): "M922222222223" overflowed the command number.
  const Machine m = parse_marlin_m503(std::string("echo:  M922222222222222222 X1\n") + kPrusa, "m.txt");
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 1250);
}

TEST(MarlinM503, BadReportsNameTheLineAndWhatIsMissing) {
  std::string t = kPronterfaceJerk;
  t.replace(t.find("Y500 Z100"), 4, "Y5x0");
  EXPECT_EQ(error_of([&] { parse_marlin_m503(t, "m.txt"); }),
            "m.txt:8:19: M201 Y: found '5x0', expected a number");
  t = kPronterfaceJerk;
  t.replace(t.find("P500.00"), 7, "P-500.0");
  EXPECT_NE(error_of([&] { parse_marlin_m503(t, "m.txt"); }).find("m.txt:10:14: M204 P"), std::string::npos)
      << error_of([&] { parse_marlin_m503(t, "m.txt"); });
  t = kPronterfaceJerk;
  t.erase(t.find("echo:  M204"), t.find("\n", t.find("echo:  M204")) - t.find("echo:  M204") + 1);
  EXPECT_EQ(error_of([&] { parse_marlin_m503(t, "m.txt"); }),
            "m.txt: found no M204 line, expected the M503 report's M201, M203, M204 and M205 "
            "(maximum acceleration, feedrate, acceleration, jerk)");
  EXPECT_NE(error_of([&] { parse_marlin_m503(std::string(kPrusa) + "echo:  M665 L250 R120\n", "d.txt"); })
                .find("found M665 (delta geometry)"),
            std::string::npos);
}

TEST(MarlinM503, LoadMachineRecognisesItByContentWhateverTheName) {
  TempDir dir("marlin_m503");
  for (const char* name : {"settings.txt", "m503", "printer.gcode"}) {
    const Machine m = load_machine(dir.write(name, kOctoPrintJd));
    EXPECT_EQ(m.firmware, Firmware::marlin) << name;
    EXPECT_DOUBLE_EQ(m.max_accel_mm_s2, 500) << name;
  }
  // machine show --json: the keep-stable keys.
  const auto j = to_json(load_machine(dir.write("m503.txt", kPronterfaceJerk)));
  EXPECT_EQ(j["printer"]["firmware"], "marlin");
  EXPECT_EQ(j["printer"]["max_accel"], 500.0);
  EXPECT_EQ(j["marlin"]["max_accel"], nlohmann::json::array({500.0, 500.0, 100.0, 5000.0}));
  EXPECT_EQ(j["marlin"]["max_feedrate"], nlohmann::json::array({500.0, 500.0, 5.0, 25.0}));
  EXPECT_EQ(j["marlin"]["jerk"], nlohmann::json::array({10.0, 10.0, 0.3, 5.0}));
}

// A Configuration.h in Marlin 2.1's form (values of the stock Ender-3 example).
const char* const kConfigurationH = R"(#pragma once
#define CONFIGURATION_H_VERSION 02010200
//#define COREXY
/**
 * #define DEFAULT_MAX_FEEDRATE { 1, 1, 1, 1 }   (inside a comment: not read)
 */
#define DEFAULT_AXIS_STEPS_PER_UNIT   { 80, 80, 400, 93 }
#define DEFAULT_MAX_FEEDRATE          { 500, 500, 5, 25 }
#define DEFAULT_MAX_ACCELERATION      { 500, 500, 100, 5000 }
#define DEFAULT_ACCELERATION          500    // X, Y, Z and E acceleration for printing moves
#define DEFAULT_RETRACT_ACCELERATION  500    // E acceleration for retracts
#define DEFAULT_TRAVEL_ACCELERATION   (DEFAULT_ACCELERATION * 2)
//#define CLASSIC_JERK
#if ENABLED(CLASSIC_JERK)
  #define DEFAULT_XJERK 10.0
  #define DEFAULT_YJERK 10.0
  #define DEFAULT_ZJERK  0.3
#endif
#define DEFAULT_EJERK    5.0  // May be used by Linear Advance
#if DISABLED(CLASSIC_JERK)
  #define JUNCTION_DEVIATION_MM 0.08 // (mm) Distance from real junction edge
#endif
//#define S_CURVE_ACCELERATION
#define DEFAULT_NOMINAL_FILAMENT_DIA 1.75
)";

const char* const kConfigurationAdvH = R"(#pragma once
#define DEFAULT_MINSEGMENTTIME        20000   // (us)
#define DEFAULT_MINIMUMFEEDRATE       0.0     // (mm/s)
#define DEFAULT_MINTRAVELFEEDRATE     0.0
#define BLOCK_BUFFER_SIZE 16
#define ARC_SUPPORT
#if ENABLED(ARC_SUPPORT)
  #define MIN_ARC_SEGMENT_MM      0.1
  #define MAX_ARC_SEGMENT_MM      1.0
  #define MIN_CIRCLE_SEGMENTS    72
  //#define ARC_SEGMENTS_PER_SEC 50
#endif
)";

TEST(MarlinConfiguration, ReadsTheLimitsAndMatchesTheEnder3Preset) {
  TempDir dir("marlin_conf");
  const std::string path = dir.write("Configuration.h", kConfigurationH);
  dir.write("Configuration_adv.h", kConfigurationAdvH);
  const Machine m = load_machine(path);
  const Machine p = preset("ender3");
  EXPECT_EQ(m.firmware, Firmware::marlin);
  EXPECT_TRUE(kinematics::is<kinematics::Cartesian>(m.kinematics));
  EXPECT_EQ(m.junction, JunctionPolicy::junction_deviation);
  EXPECT_DOUBLE_EQ(m.junction_deviation_mm, p.junction_deviation_mm);
  EXPECT_EQ(m.max_feedrate_mm_s, p.max_feedrate_mm_s);
  EXPECT_EQ(m.max_axis_accel_mm_s2, p.max_axis_accel_mm_s2);
  EXPECT_DOUBLE_EQ(m.print_accel_mm_s2, 500);
  EXPECT_DOUBLE_EQ(m.retract_accel_mm_s2, 500);
  EXPECT_DOUBLE_EQ(m.travel_accel_mm_s2, 1000);  // the expression (DEFAULT_ACCELERATION * 2)
  EXPECT_DOUBLE_EQ(m.jerk_mm_s[3], 5.0);
  EXPECT_DOUBLE_EQ(m.min_segment_time_s, p.min_segment_time_s);
  EXPECT_EQ(m.block_buffer_size, p.block_buffer_size);
  EXPECT_DOUBLE_EQ(m.arcs.min_arc_segment_mm, p.arcs.min_arc_segment_mm);
  EXPECT_DOUBLE_EQ(m.arcs.max_arc_segment_mm, p.arcs.max_arc_segment_mm);
  EXPECT_EQ(m.arcs.min_circle_segments, p.arcs.min_circle_segments);
  for (const char* s : {"x", "y", "z", "e"}) {
    EXPECT_DOUBLE_EQ(m.steppers.at(s).steps_per_mm(), p.steppers.at(s).steps_per_mm()) << s;
  }
}

TEST(MarlinConfiguration, ClassicJerkAndCoreXyWhenDefined) {
  std::string t = kConfigurationH;
  t.replace(t.find("//#define CLASSIC_JERK"), 22, "#define CLASSIC_JERK");
  t.replace(t.find("//#define COREXY"), 16, "#define COREXY");
  const Machine m = parse_marlin_configuration(t, "Configuration.h");
  EXPECT_EQ(m.junction, JunctionPolicy::classic_jerk);
  EXPECT_EQ(m.jerk_mm_s, (std::array<double, 4>{10, 10, 0.3, 5}));
  EXPECT_TRUE(kinematics::is<kinematics::CoreXY>(m.kinematics));
}

TEST(MarlinConfiguration, ConditionalsDecideWhichDefinitionApplies) {
  // Marlin 2.1's Configuration_adv.h: the planner buffer depends on the SD card; the jerk
  // values exist only with CLASSIC_JERK; a derived switch nobody defines stays undecided.
  const std::string adv = R"(#if ALL(HAS_MEDIA, DIRECT_STEPPING)
  #define BLOCK_BUFFER_SIZE  8
#elif HAS_MEDIA
  #define BLOCK_BUFFER_SIZE 32
#else
  #define BLOCK_BUFFER_SIZE 16
#endif
#if HAS_SOMETHING_DERIVED
  #define DEFAULT_MINSEGMENTTIME 30000
#else
  #define DEFAULT_MINSEGMENTTIME 10000
#endif
#ifndef DEFAULT_MINIMUMFEEDRATE
  #define DEFAULT_MINIMUMFEEDRATE 0.5
#endif
#if EXTRUDERS > 1 && ENABLED(SDSUPPORT)
  #define DEFAULT_MINTRAVELFEEDRATE 7
#endif
)";
  const Machine no_sd = parse_marlin_configuration(kConfigurationH, "c.h", adv, "a.h");
  EXPECT_EQ(no_sd.block_buffer_size, 16);
  EXPECT_DOUBLE_EQ(no_sd.jerk_mm_s[0], Machine{}.jerk_mm_s[0]);  // DEFAULT_XJERK is off
  EXPECT_DOUBLE_EQ(no_sd.min_segment_time_s, 0.03);  // undecided: the first of the chain
  EXPECT_DOUBLE_EQ(no_sd.min_feedrate_mm_s, 0.5);
  EXPECT_DOUBLE_EQ(no_sd.min_travel_feedrate_mm_s, 0.0);  // EXTRUDERS undefined = 0
  const std::string sd = std::string(kConfigurationH) + "#define SDSUPPORT\n#define EXTRUDERS 2\n";
  const Machine with_sd = parse_marlin_configuration(sd, "c.h", adv, "a.h");
  EXPECT_EQ(with_sd.block_buffer_size, 32);
  EXPECT_DOUBLE_EQ(with_sd.min_travel_feedrate_mm_s, 7.0);
}

TEST(MarlinConfiguration, FilesWithoutLimitsAreErrorsNeverTheDefaultMachine) {
  TempDir dir("marlin_conf_bad");
  // Configuration_adv.h alone, and a #define-only file without the limits under any name.
  EXPECT_NE(error_of([&] { load_machine(dir.write("Configuration_adv.h", kConfigurationAdvH)); })
                .find("found no DEFAULT_MAX_FEEDRATE"),
            std::string::npos);
  EXPECT_NE(error_of([&] { load_machine(dir.write("printer", "#define FOO 1\n#define BAR 2\n")); })
                .find("found no DEFAULT_MAX_FEEDRATE"),
            std::string::npos);
  // The same lines in a .toml, and an empty .toml: no settings, an error.
  EXPECT_NE(error_of([&] { load_machine(dir.write("p.toml", "#define FOO 1\n")); }).find("found no setting"),
            std::string::npos);
  EXPECT_EQ(error_of([&] { load_machine(dir.write("e.toml", "")); }).rfind(dir.path().string() + "/e.toml: found no setting", 0),
            0u);
  std::string t = kConfigurationH;
  t.replace(t.find("{ 500, 500, 5, 25 }"), 19, "{ 500, 500, 5 }");
  EXPECT_EQ(error_of([&] { parse_marlin_configuration(t, "Configuration.h"); }),
            "Configuration.h:8:39: DEFAULT_MAX_FEEDRATE: found 3 values, expected at least 4 (x, y, z, e)");
  t = kConfigurationH;
  t.replace(t.find("500    // X, Y"), 3, "5o0");
  EXPECT_NE(error_of([&] { parse_marlin_configuration(t, "Configuration.h"); }).find("Configuration.h:10:39: DEFAULT_ACCELERATION"),
            std::string::npos) << error_of([&] { parse_marlin_configuration(t, "Configuration.h"); });
  EXPECT_NE(error_of([&] { parse_marlin_configuration(std::string(kConfigurationH) + "#define DELTA\n", "c.h"); })
                .find("found DELTA kinematics"),
            std::string::npos);
}

}  // namespace
}  // namespace amctl::machine
