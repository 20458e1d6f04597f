#pragma once
// The look-ahead velocity planner.
//
// Reference behaviour is Klipper's toolhead (klippy/toolhead.py, read for its behaviour):
//  - each move's cruise speed is the requested speed capped by max_velocity, Z and
//    extruder limits;
//  - the speed at a junction is limited by the "approximated centripetal velocity" derived
//    from square_corner_velocity (junction deviation jd = scv^2 (sqrt2 - 1) / accel), by half
//    the move length (centripetal limit), by the extruder's instantaneous_corner_velocity and
//    by what the previous move can reach;
//  - a second, smoothed pass with the pseudo-acceleration accel (1 - minimum_cruise_ratio)
//    decides where moves cruise, so short zig-zags do not accelerate to full speed;
//  - the queue is flushed lazily once 0.15 s of moves are queued (1 s after a full flush),
//    fully at dwells, M400 and position resets.
// Marlin's junction deviation (with its small-segment limit) and classic jerk are the other
// junction policies; Marlin also plans over a finite block buffer (16 moves by default).
// Derivations: docs/planner.md.
#include <algorithm>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "amctl/gcode/events.hpp"
#include "amctl/machine/machine.hpp"
#include "amctl/plan/planned_move.hpp"

namespace amctl::plan {

/// Receives the planner's output in time order.
class PlanSink {
 public:
  virtual ~PlanSink() = default;
  virtual void on_planned(const PlannedMove& move) = 0;
  /// A pause with the toolhead at rest (G4), starting at start_time_s.
  virtual void on_dwell(double start_time_s, double duration_s, std::uint64_t line) {
    (void)start_time_s; (void)duration_s; (void)line;
  }
  /// A heater command taking effect at print time `time_s` (after the moves before it).
  virtual void on_heater(double time_s, const gcode::HeaterCommand& cmd) { (void)time_s; (void)cmd; }
  virtual void on_progress(double time_s, const gcode::ProgressMarker& m) { (void)time_s; (void)m; }
  virtual void on_untimed(double time_s, std::string_view name, std::uint64_t line) {
    (void)time_s; (void)name; (void)line;
  }
  virtual void on_layer_change(double time_s, std::int32_t layer, std::uint64_t line) {
    (void)time_s; (void)layer; (void)line;
  }
  virtual void on_fan(double time_s, double fraction, std::uint64_t line) {
    (void)time_s; (void)fraction; (void)line;
  }
};

struct PlannerOptions {
  /// Overrides Machine::block_buffer_size when set (0 = unlimited look-ahead).
  std::optional<std::size_t> block_buffer_size;
  /// Upper bound on queued moves before a forced flush (Klipper's lazy flush, or the oldest
  /// block of an unlimited Marlin buffer), and on non-motion events waiting behind queued
  /// moves before a forced full stop; it keeps memory bounded on pathological input without
  /// changing results on real files.
  std::size_t max_queue = 1u << 16;
  /// Marlin's MINIMUM_PLANNER_SPEED [mm/s].
  double minimum_planner_speed_mm_s = 0.05;
};

/// Count of moves whose request the machine refused or trimmed.
struct PlannerDiagnostics {
  std::uint64_t moves = 0;
  std::uint64_t zero_length_moves = 0;
  std::uint64_t speed_limited_moves = 0;   ///< requested speed above a limit
  std::uint64_t extrude_only_moves = 0;
  std::uint64_t forced_flushes = 0;        ///< max_queue reached (0 on real files; warned)
  std::uint64_t full_stops = 0;            ///< flushes to zero speed (dwell, M400, ...)
  std::vector<std::string> warnings;       ///< e.g. over-extrusion (Klipper would refuse)
};

class Planner final : public gcode::EventSink {
 public:
  Planner(const machine::Machine& machine, PlanSink& sink, PlannerOptions options = {});

  // gcode::EventSink
  void on_move(const gcode::MoveRequest& move) override;
  void on_dwell(double duration_s, std::uint64_t line) override;
  void on_wait_moves(std::uint64_t line) override;
  void on_set_position(const std::array<double, 4>& pos_mm, std::uint64_t line) override;
  void on_limits(const gcode::LimitsCommand& cmd) override;
  void on_heater(const gcode::HeaterCommand& cmd) override;
  void on_fan(double fraction, std::uint64_t line) override;
  void on_progress(const gcode::ProgressMarker& m) override;
  void on_layer_change(std::int32_t layer, std::uint64_t line) override;
  void on_untimed(std::string_view name, std::uint64_t line) override;

  /// Plans and emits every queued move, ending at rest. Call once at end of input.
  void finish();

  /// Print time reached by the moves emitted so far [s].
  [[nodiscard]] double print_time_s() const { return print_time_s_; }
  [[nodiscard]] const PlannerDiagnostics& diagnostics() const { return diag_; }

  /// Current limits (after G-code changes) — useful for reports and tests.
  struct Limits {
    double max_velocity_mm_s;
    double accel_mm_s2;             ///< Klipper toolhead accel / Marlin print accel
    double travel_accel_mm_s2;      ///< Marlin
    double retract_accel_mm_s2;     ///< Marlin
    double square_corner_velocity_mm_s;
    double minimum_cruise_ratio;
    std::optional<double> accel_to_decel_mm_s2;  ///< old Klipper setting, when given
    std::array<double, 4> max_feedrate_mm_s;
    std::array<double, 4> max_axis_accel_mm_s2;
    std::array<double, 4> jerk_mm_s;
    double junction_deviation_mm;
    double min_feedrate_mm_s;
    double min_travel_feedrate_mm_s;
  };
  [[nodiscard]] const Limits& limits() const { return lim_; }

 private:
  struct Move {
    PlannedMove out;           // geometry and identity; speeds/times filled at flush
    double max_cruise_v2 = 0;
    double max_start_v2 = 0;
    double delta_v2 = 0;
    double max_mcr_start_v2 = 0;
    double mcr_delta_v2 = 0;
    double mcr_accel = 0;           // pseudo-accel of the smoothed pass (mcr_delta_v2 / 2D)
    // scurve7: last reachable-speed evaluation of each pass (flushes revisit queued moves,
    // mostly with the same neighbour speed).
    mutable double reach_from_v2 = -1, reach_to_v2 = 0, mcr_reach_from_v2 = -1, mcr_reach_to_v2 = 0;
    double min_move_t = 0;
    double planned_start_v2 = -1;   // Marlin buffer: this block's start in the last backward pass
    double junction_deviation = 0;  // Klipper jd of the limits in force for this move
    bool kinematic = true;
    // Marlin classic jerk bookkeeping
    std::array<double, 4> axis_v{};  // per-axis velocity at nominal speed
    double nominal_v = 0;
    double safe_v = 0;
    std::uint64_t seq = 0;  // arrival order, for events queued behind this move
  };

  // A non-motion event that takes effect once every move queued before it has run.
  struct PendingEvent {
    enum class Kind : std::uint8_t { heater, fan, progress, layer, untimed } kind = Kind::heater;
    std::uint64_t after_seq = 0;
    gcode::HeaterCommand heater{};
    gcode::ProgressMarker progress{};
    double fan = 0.0;
    std::int32_t layer = 0;
    std::uint64_t line = 0;
    std::string name;
  };
  void post(PendingEvent&& e);
  void note_forced_flush(std::uint64_t line, const char* what);

  /// FIFO over a vector: O(1) pops from the front without deque's per-block allocations.
  /// Slots are recycled, not destroyed: emplace_back() returns a slot that may hold an old
  /// move, and Planner::on_move() assigns every field (value-initialising a Move, ~300
  /// bytes, was a quarter of on_move's time).
  class MoveQueue {
   public:
    [[nodiscard]] std::size_t size() const { return end_ - head_; }
    [[nodiscard]] bool empty() const { return size() == 0; }
    Move& operator[](std::size_t i) { return buf_[head_ + i]; }
    Move& front() { return buf_[head_]; }
    Move& back() { return buf_[end_ - 1]; }
    Move& emplace_back() {
      if (end_ < buf_.size()) return buf_[end_++];
      ++end_;
      return buf_.emplace_back();
    }
    void pop_back() { --end_; }
    void pop_front(std::size_t n = 1) {
      head_ += n;
      if (head_ == end_) {
        head_ = end_ = 0;
      } else if (head_ >= 64 && 2 * head_ >= end_) {
        std::move(buf_.begin() + static_cast<std::ptrdiff_t>(head_),
                  buf_.begin() + static_cast<std::ptrdiff_t>(end_), buf_.begin());
        end_ -= head_;
        head_ = 0;
      }
    }

   private:
    std::vector<Move> buf_;
    std::size_t head_ = 0;
    std::size_t end_ = 0;
  };
  void fire(const PendingEvent& e);

  void add_queued_move();
  void flush(bool lazy);
  void emit(Move& m, double start_v2, double cruise_v2, double end_v2);
  // The two places where the ramp shape enters the look-ahead (docs/planner.md, "Jerk-limited
  // profiles"): the squared speed reachable over a move from from_v2 (accelerating, or by
  // time reversal braking), and the squared cruise peak between two end speeds.
  // The smoothed (minimum cruise ratio) pass uses the same shapes with the pseudo-accel.
  [[nodiscard]] double reach_v2(double from_v2, const Move& m) const;
  [[nodiscard]] double reach_mcr_v2(double from_v2, const Move& m) const;
  [[nodiscard]] double scurve_peak_v2(double start_v2, double end_v2, const Move& m,
                                      double accel, double cap_v2) const;
  void full_stop();
  void junction_klipper(Move& m, const Move& prev) const;
  void junction_marlin_jd(Move& m, const Move& prev) const;
  void junction_classic_jerk(Move& m, const Move& prev);
  void flush_marlin_head();
  [[nodiscard]] double klipper_junction_deviation() const;
  void apply_limits(const gcode::LimitsCommand& cmd);
  /// Recomputes the cached values that depend on lim_ (after a limits command).
  void update_derived_limits();
  [[nodiscard]] double mcr_pseudo_accel() const;

  machine::Machine machine_;
  PlanSink& sink_;
  PlannerOptions opt_;
  Limits lim_{};
  MoveQueue queue_;
  double junction_flush_s_ = 1.0;
  std::size_t buffer_size_ = 16;
  double print_time_s_ = 0.0;
  double prev_safe_v_ = 0.0;
  bool jerk_limited_ = false;  // machine profile is scurve7: ramps are timed jerk-limited
  // Constants of the machine used on every move (set once in the constructor).
  bool klipper_ = true;
  bool classic_jerk_ = false;
  // emit(): the last 0.5 / accel and the last end speed with its square root.
  double emit_a_ = 0, emit_half_inv_a_ = 0, emit_last_v2_ = 0, emit_last_v_ = 0;
  double z_velocity_mm_s_ = 0, z_accel_mm_s2_ = 0;
  double filament_area_mm2_ = 0, extrude_only_velocity_mm_s_ = 0, extrude_only_accel_mm_s2_ = 0;
  double max_cross_section_mm2_ = 0, max_extrude_ratio_ = 0;
  // Derived from lim_, refreshed by update_derived_limits().
  double mcr_accel_mm_s2_ = 0, junction_deviation_mm_ = 0;
  PlannerDiagnostics diag_;
  // Reusable scratch for flush().
  struct JunctionInfo { double start_v2; double cruise_v2; bool has_cruise; double next_start_v2; };
  std::vector<JunctionInfo> scratch_;
  std::uint64_t warned_overextrusion_ = 0;
  std::uint64_t next_seq_ = 1;
  std::deque<PendingEvent> pending_;
};

}  // namespace amctl::plan
