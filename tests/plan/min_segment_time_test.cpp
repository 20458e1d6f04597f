// Marlin's SLOWDOWN (M205 B, marlin.min_segment_time) against its rule written out by hand:
// the k-th block after a synchronisation finds k blocks queued; when 2 <= k <= B/2 - 1 and
// the segment would take t < T, it is slowed to last t + 2 (T - t) / k (docs/planner.md,
// "Minimum segment time").
#include <cstddef>
#include <string>
#include <vector>

#include <algorithm>

#include <gtest/gtest.h>

#include "amctl/gcode/interpreter.hpp"
#include "amctl/gcode/line_reader.hpp"
#include "amctl/plan/estimate.hpp"
#include "amctl/plan/planner.hpp"

namespace amctl::plan {
namespace {

struct Collect : PlanSink {
  std::vector<PlannedMove> moves;
  void on_planned(const PlannedMove& m) override { moves.push_back(m); }
};

// Collinear segments with an acceleration so high that every block cruises at its nominal
// speed: the planned cruise speed is then exactly the speed SLOWDOWN left.
machine::Machine marlin(double min_segment_time_s, int buffer) {
  machine::Machine m;
  m.firmware = machine::Firmware::marlin;
  m.junction = machine::JunctionPolicy::junction_deviation;
  m.print_accel_mm_s2 = m.travel_accel_mm_s2 = m.retract_accel_mm_s2 = 1e6;
  m.max_axis_accel_mm_s2 = {1e6, 1e6, 1e6, 1e6};
  m.max_feedrate_mm_s = {500, 500, 500, 500};
  m.junction_deviation_mm = 0.05;
  m.min_segment_time_s = min_segment_time_s;
  m.block_buffer_size = buffer;
  return m;
}

// Expected nominal speed of block k after a stop: D = 0.5 mm at 100 mm/s takes 5 ms.
double expected_speed(std::size_t k, double min_t, std::size_t buffer) {
  const double d = 0.5, v = 100.0, t = d / v;
  if (k < 2 || k + 1 > buffer / 2 || !(t < min_t)) return v;
  return d / (t + 2.0 * (min_t - t) / static_cast<double>(k));
}

void run_line(Planner& p, double& x, int n) {
  for (int i = 0; i < n; ++i, x += 0.5) p.on_move(gcode::MoveRequest{{x, 0, 0, 0}, {x + 0.5, 0, 0, 0}, 100.0, 1});
}

TEST(MinSegmentTime, FirstBlocksAfterEachStopAreSlowedByMarlinsRule) {
  for (const std::size_t buffer : {16u, 8u, 64u}) {
    Collect c;
    Planner p(marlin(0.02, static_cast<int>(buffer)), c);
    double x = 0;
    run_line(p, x, 40);
    p.on_dwell(0.0, 1);  // G4: the buffer drains, the next blocks refill it from empty
    run_line(p, x, 40);
    p.finish();
    ASSERT_EQ(c.moves.size(), 80u);
    for (std::size_t i = 0; i < 80; ++i) {
      const std::size_t k = i % 40;
      // The last block brakes to rest; its cruise is still the nominal speed (1e6 mm/s^2).
      EXPECT_NEAR(c.moves[i].cruise_v_mm_s, expected_speed(k, 0.02, buffer), 1e-9)
          << "buffer " << buffer << " block " << i;
    }
    std::uint64_t slowed = 0;
    for (std::size_t k = 0; k < 40; ++k) slowed += expected_speed(k, 0.02, buffer) < 100.0;
    EXPECT_EQ(p.diagnostics().min_segment_time_slowdowns, 2 * slowed);
    EXPECT_EQ(p.diagnostics().speed_limited_moves, 0u);
  }
}

TEST(MinSegmentTime, SecondBlockAfterAStopLastsExactlyTheMinimumSegmentTime) {
  // k = 2: t + 2 (T - t) / 2 = T.
  Collect c;
  Planner p(marlin(0.02, 16), c);
  double x = 0;
  run_line(p, x, 4);
  p.finish();
  EXPECT_NEAR(0.5 / c.moves[2].cruise_v_mm_s, 0.02, 1e-15);
}

TEST(MinSegmentTime, NoSlowdownWhenTheWindowIsEmptyOrTheSegmentIsLongEnough) {
  // B/2 - 1 < 2 (0, 1: unlimited look-ahead, no ring). A machine's buffer is >= 1 (the schema);
  // 0 is the planner option for unlimited look-ahead.
  for (const int buffer : {0, 1, 2, 4}) {
    Collect c;
    PlannerOptions o;
    o.block_buffer_size = static_cast<std::size_t>(buffer);
    Planner p(marlin(0.02, std::max(buffer, 1)), c, o);
    double x = 0;
    run_line(p, x, 20);
    p.finish();
    EXPECT_EQ(p.diagnostics().min_segment_time_slowdowns, 0u) << buffer;
  }
  Collect c;
  Planner p(marlin(0.004, 16), c);  // 5 ms segments are longer than 4 ms
  double x = 0;
  run_line(p, x, 20);
  p.finish();
  EXPECT_EQ(p.diagnostics().min_segment_time_slowdowns, 0u);
}

double estimate_with(const std::string& gcode, const machine::Machine& m, std::uint64_t* slowed = nullptr) {
  const auto r = estimate_text(gcode, "t", m);
  if (slowed != nullptr) *slowed = r.diagnostics.min_segment_time_slowdowns;
  return r.total_time_s;
}

std::string line_gcode(const std::string& head) {
  std::string g = head + "G1 F6000\n";
  for (int i = 1; i <= 20; ++i) g += "G1 X" + std::to_string(i * 0.5) + "\n";
  return g;
}

TEST(MinSegmentTime, M205BSetsItInMicrosecondsOnMarlinOnly) {
  std::uint64_t slowed = 0;
  // Machine value 0 (off); M205 B20000 turns it on: as the machine key 0.02 s.
  const double on = estimate_with(line_gcode("M205 B20000\n"), marlin(0.0, 16), &slowed);
  EXPECT_EQ(slowed, 6u);  // blocks 2..7
  EXPECT_DOUBLE_EQ(on, estimate_with(line_gcode(""), marlin(0.02, 16)));
  // M205 B0 turns it off.
  const double off = estimate_with(line_gcode("M205 B0\n"), marlin(0.02, 16), &slowed);
  EXPECT_EQ(slowed, 0u);
  EXPECT_DOUBLE_EQ(off, estimate_with(line_gcode(""), marlin(0.0, 16)));
  EXPECT_GT(on, off);
  // Neither Klipper nor RepRapFirmware has SLOWDOWN.
  for (const auto fw : {machine::Firmware::klipper, machine::Firmware::reprap}) {
    machine::Machine m = marlin(0.02, 16);
    m.firmware = fw;
    if (fw == machine::Firmware::klipper) m.junction = machine::JunctionPolicy::square_corner_velocity;
    estimate_with(line_gcode("M205 B20000\n"), m, &slowed);
    EXPECT_EQ(slowed, 0u);
  }
}

TEST(MinSegmentTime, LimitsReportTheValueInSeconds) {
  Collect c;
  Planner p(marlin(0.02, 16), c);
  EXPECT_DOUBLE_EQ(p.limits().min_segment_time_s, 0.02);
  gcode::Interpreter in({}, "t");
  gcode::LineReader reader("M205 B12500\n", "t");
  in.run(reader, p);
  EXPECT_DOUBLE_EQ(p.limits().min_segment_time_s, 0.0125);
}

}  // namespace
}  // namespace amctl::plan
