#include "amctl/steppers/steps.hpp"

#include "amctl/steppers/step_filter.hpp"
#include "amctl/steppers/step_rate.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/machine/delta.hpp"
#include "amctl/machine/loader.hpp"
#include "amctl/trajectory/trajectory.hpp"

namespace amctl::steppers {

using plan::PathPiece;
using plan::PlannedMove;

// ---------------------------------------------------------------------------------------
// Channels

double step_distance_mm(const machine::Stepper& s, const std::string& label) {
  if (!(std::isfinite(s.rotation_distance_mm) && s.rotation_distance_mm > 0.0)) {
    throw Error(fmt::format("{}.rotation_distance: must be a positive number of mm, got {}", label,
                            s.rotation_distance_mm));
  }
  if (s.microsteps <= 0) {
    throw Error(fmt::format("{}.microsteps: must be at least 1, got {}", label, s.microsteps));
  }
  if (s.full_steps_per_rotation <= 0) {
    throw Error(fmt::format("{}.full_steps_per_rotation: must be at least 1, got {}", label,
                            s.full_steps_per_rotation));
  }
  // stepper.py: step_dist = rotation_distance / (full_steps * microsteps * gearing); the
  // machine holds rotation_distance / gearing already.
  return s.rotation_distance_mm /
         (static_cast<double>(s.full_steps_per_rotation) * static_cast<double>(s.microsteps));
}

namespace {

std::string klipper_name(const std::string& key) {
  if (key[0] == 'e' && std::all_of(key.begin() + 1, key.end(), [](char c) { return c >= '0' && c <= '9'; })) {
    return "extruder" + key.substr(1);
  }
  return "stepper_" + key;
}

// Numeric suffix order: "z" before "z1" before "z2" ... "z10".
bool key_less(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return a.size() < b.size();
  return a < b;
}

/// generic_cartesian: "stepper NAME" rows from the carriages (generic_cartesian_geometry), in
/// the order of Machine::steppers, then the extruder.
std::vector<StepperChannel> generic_channels(const machine::Machine& m) {
  if (m.steppers.find("e") == m.steppers.end()) {
    throw Error(fmt::format("machine '{}' has no stepper section for extruder: step generation "
                            "needs rotation_distance and microsteps of every motor (a Klipper "
                            "printer.cfg has [extruder]; a machine TOML [stepper_e])",
                            m.name));
  }
  const machine::GenericCartesianGeometry g = machine::generic_cartesian_geometry(m);
  std::vector<StepperChannel> out;
  for (const machine::GenericStepper& gs : g.steppers) {
    StepperChannel c;
    c.key = gs.name;
    c.name = "stepper " + gs.name;  // Klipper's name of a [stepper NAME]
    c.step_distance_mm = step_distance_mm(m.steppers.at(gs.name), c.name);
    c.row = {gs.coeffs[0], gs.coeffs[1], gs.coeffs[2], 0.0};
    out.push_back(std::move(c));
  }
  StepperChannel e;
  e.key = "e";
  e.name = "extruder";
  e.step_distance_mm = step_distance_mm(m.steppers.at("e"), e.name);
  e.row = {0, 0, 0, 1};
  out.push_back(std::move(e));
  return out;
}

}  // namespace

std::vector<StepperChannel> stepper_channels(const machine::Machine& m) {
  using K = machine::Kinematics;
  const bool winch = m.kinematics == K::winch;
  const bool delta = m.kinematics == K::delta;
  const bool lettered_motors = delta || winch;
  const bool none = m.kinematics == K::none;
  const bool deltesian = m.kinematics == K::deltesian;
  if (m.kinematics == K::generic_cartesian) return generic_channels(m);
  const bool polar = m.kinematics == K::polar;
  const bool rotary = m.kinematics == K::rotary_delta;
  std::vector<const char*> required;
  if (lettered_motors || rotary) required = {"a", "b", "c", "e"};
  else if (polar) required = {"bed", "arm", "z", "e"};
  else if (deltesian) required = {"left", "right", "y", "e"};
  else if (none) required = {"e"};
  else required = {"x", "y", "z", "e"};
  std::vector<std::string> missing;
  for (const char* k : required) {
    if (m.steppers.find(k) == m.steppers.end()) missing.push_back(klipper_name(k));
  }
  if (!missing.empty()) {
    std::string list;
    for (const std::string& s : missing) list += (list.empty() ? "" : ", ") + s;
    throw Error(fmt::format(
        "machine '{}' has no stepper section for {}: step generation needs rotation_distance "
        "and microsteps of every motor (a Klipper printer.cfg has [stepper_x], [stepper_y], "
        "[stepper_z] ([stepper_a], [stepper_b], [stepper_c] on a delta), [extruder]; a machine "
        "TOML needs the same sections, the extruder as [stepper_e])",
        m.name, list));
  }
  auto is_tower = [&](const std::string& k) {
    return k == "a" || k == "b" || k == "c" || (winch && k == "d");
  };
  std::vector<std::string> keys;
  for (const auto& [k, s] : m.steppers) {
    if (k[0] == 'e' && k != "e") continue;  // extra extruders: amctl plans one E axis
    if (polar) {
      if (k == "bed" || k == "arm" || k[0] == 'z' || k == "e") keys.push_back(k);
      continue;
    }
    if (k[0] != 'e' && (none || is_tower(k) != (lettered_motors || rotary))) continue;  // not a motor here
    const bool side = k == "left" || k == "right";
    if (side != deltesian && side) continue;
    if (deltesian && !side && k != "y" && k[0] != 'e') continue;
    keys.push_back(k);
  }
  const auto rank = [](const std::string& k) {
    if (k == "left" || k == "bed") return -2;
    if (k == "right" || k == "arm") return -1;
    switch (k[0]) {
      case 'x': case 'a': return 0;
      case 'y': case 'b': return 1;
      case 'z': case 'c': return 2;
      case 'd': return 3;
      default: return 4;
    }
  };
  std::sort(keys.begin(), keys.end(), [&](const std::string& a, const std::string& b) {
    if (rank(a) != rank(b)) return rank(a) < rank(b);
    return key_less(a, b);
  });
  using Row = std::array<double, 4>;
  Row row_x{1, 0, 0, 0}, row_y{0, 1, 0, 0}, row_z{0, 0, 1, 0};
  switch (m.kinematics) {
    case K::corexy: row_x = {1, 1, 0, 0}; row_y = {1, -1, 0, 0}; break;        // kin_corexy.c + / -
    case K::corexz: row_x = {1, 0, 1, 0}; row_z = {1, 0, -1, 0}; break;        // kin_corexz.c + / -
    case K::hybrid_corexy: row_x = {1, -1, 0, 0}; break;                      // corexy '-'
    case K::hybrid_corexz: row_x = {1, 0, -1, 0}; break;                      // corexz '-'
    default: break;
  }
  std::optional<machine::DeltaGeometry> g;
  if (delta) g = machine::delta_geometry(m);
  std::optional<machine::DeltesianGeometry> dg;
  if (deltesian) dg = machine::deltesian_geometry(m);
  std::shared_ptr<const machine::RotaryDeltaGeometry> rg;
  if (rotary) rg = std::make_shared<machine::RotaryDeltaGeometry>(machine::rotary_delta_geometry(m));
  std::vector<StepperChannel> out;
  for (const std::string& k : keys) {
    StepperChannel c;
    c.key = k;
    c.name = klipper_name(k);
    c.step_distance_mm = step_distance_mm(m.steppers.at(k), c.name);
    if (polar && (k == "bed" || k == "arm")) {
      c.curve = k == "bed" ? StepperChannel::Curve::polar_angle : StepperChannel::Curve::polar_radius;
      out.push_back(std::move(c));
      continue;
    }
    if (rotary && k != "e") {
      c.curve = StepperChannel::Curve::rotary_arm;
      c.rotary_arm = k[0] - 'a';
      c.rotary = rg;
      out.push_back(std::move(c));
      continue;
    }
    if (deltesian && (k == "left" || k == "right")) {
      const std::size_t i = k == "left" ? 0 : 1;
      c.arm2_mm2 = dg->arm2_mm2[i];
      c.tower_x_mm = dg->tower_x_mm[i];
      c.planar = true;
      out.push_back(std::move(c));
      continue;
    }
    switch (k[0]) {
      case 'x': c.row = row_x; break;
      case 'y': c.row = row_y; break;
      case 'z': c.row = row_z; break;
      case 'a': case 'b': case 'c': case 'd': {
        if (winch) {
          const machine::Stepper& s = m.steppers.at(k);
          c.cable = true;
          c.anchor_mm = {s.anchor_x_mm.value_or(0.0), s.anchor_y_mm.value_or(0.0),
                         s.anchor_z_mm.value_or(0.0)};
          break;
        }
        const auto i = static_cast<std::size_t>(k[0] - 'a');
        c.arm2_mm2 = g->arm2_mm2[i];
        c.tower_x_mm = g->tower_x_mm[i];
        c.tower_y_mm = g->tower_y_mm[i];
        break;
      }
      default: c.row = {0, 0, 0, 1}; break;
    }
    out.push_back(std::move(c));
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Root finding on one piece

namespace {

inline double horner(const PathPiece& p, double tau, double& deriv) {
  double d0 = 0.0, d1 = 0.0;
  for (int k = p.degree; k >= 0; --k) {
    d1 = d1 * tau + d0;
    d0 = d0 * tau + p.c[static_cast<std::size_t>(k)];
  }
  deriv = d1;
  return d0;
}

}  // namespace

double solve_crossing_s(const PathPiece& p, double s_target, double lo) {
  const double T = p.duration_s;
  double tau = lo;
  if (p.degree == 1) {
    if (p.c[1] > 0.0) tau = (s_target - p.c[0]) / p.c[1];
  } else if (p.degree == 2) {
    // c2 tau^2 + c1 tau - D = 0 with c1 = v(0) >= 0: tau = 2D / (c1 + sqrt(c1^2 + 4 c2 D)),
    // free of cancellation for both signs of c2.
    const double D = s_target - p.c[0];
    const double disc = std::max(0.0, p.c[1] * p.c[1] + 4.0 * p.c[2] * D);
    const double den = p.c[1] + std::sqrt(disc);
    if (den > 0.0) tau = 2.0 * D / den;
  } else if (p.degree >= 3) {
    double a = lo, b = T, v = 0.0;
    const double fa = horner(p, a, v) - s_target;
    if (fa >= 0.0) return a;
    tau = v > 0.0 ? a - fa / v : 0.5 * (a + b);
    for (int it = 0; it < 200; ++it) {
      if (!(tau > a && tau < b)) tau = 0.5 * (a + b);
      const double f = horner(p, tau, v) - s_target;
      if (f == 0.0) return tau;
      if (f > 0.0) b = tau; else a = tau;
      const double step = v > 0.0 ? f / v : 0.0;
      const double next = tau - step;
      if (v > 0.0 && std::abs(step) <= 1e-14 * (1.0 + T)) {
        tau = std::clamp(next, a, b);
        break;
      }
      if (b - a <= 1e-13) {
        tau = 0.5 * (a + b);
        break;
      }
      tau = v > 0.0 ? next : 0.5 * (a + b);
    }
  }
  return std::clamp(tau, lo, T);
}

// ---------------------------------------------------------------------------------------
// Generator

StepGenerator::StepGenerator(std::vector<StepperChannel> channels)
    : channels_(std::move(channels)),
      state_(channels_.size()),
      stats_(channels_.size()),
      scratch_(channels_.size()) {
  for (const StepperChannel& c : channels_) {
    AMCTL_CHECK(c.step_distance_mm > 0.0, "step distance must be positive");
  }
}

void StepGenerator::add_move(const PlannedMove& move, std::vector<Step>& out) {
  piece_count_ = trajectory::move_pieces(move, pieces_);
  std::size_t active = 0, last_active = 0;
  for (std::uint32_t c = 0; c < channels_.size(); ++c) {
    scratch_[c].clear();
    stepper_move(c, move, scratch_[c]);
    if (!scratch_[c].empty()) {
      ++active;
      last_active = c;
    }
  }
  if (active == 0) return;
  if (active == 1) {
    out.insert(out.end(), scratch_[last_active].begin(), scratch_[last_active].end());
    return;
  }
  // k-way merge by time (ties: channel order); few channels, so a linear scan of the heads.
  std::array<std::size_t, 16> head_small{};
  std::vector<std::size_t> head_big;
  std::size_t* head = head_small.data();
  if (channels_.size() > head_small.size()) {
    head_big.assign(channels_.size(), 0);
    head = head_big.data();
  }
  std::size_t total = 0;
  for (const auto& s : scratch_) total += s.size();
  out.reserve(out.size() + total);
  for (std::size_t k = 0; k < total; ++k) {
    std::size_t best = channels_.size();
    double best_t = 0.0;
    for (std::size_t c = 0; c < channels_.size(); ++c) {
      if (head[c] < scratch_[c].size()) {
        const double t = scratch_[c][head[c]].time_s;
        if (best == channels_.size() || t < best_t) {
          best = c;
          best_t = t;
        }
      }
    }
    out.push_back(scratch_[best][head[best]++]);
  }
}

namespace {

/// Maps path distances, visited in increasing order, to times over a move's pieces.
class PieceCursor {
 public:
  PieceCursor(const std::array<PathPiece, 7>& pieces, std::size_t count, double t0)
      : pieces_(pieces), count_(count), t0_(t0) {
    double d = 0.0;
    end_s_ = horner(pieces_[0], pieces_[0].duration_s, d);
  }
  double time_at(double s_target) {
    double d = 0.0;
    while (i_ + 1 < count_ && s_target > end_s_) {
      t0_ += pieces_[i_].duration_s;
      ++i_;
      end_s_ = horner(pieces_[i_], pieces_[i_].duration_s, d);
      lo_ = 0.0;
    }
    lo_ = solve_crossing_s(pieces_[i_], s_target, lo_);
    return t0_ + lo_;
  }

 private:
  const std::array<PathPiece, 7>& pieces_;
  std::size_t count_;
  std::size_t i_ = 0;
  double t0_;
  double end_s_ = 0.0;
  double lo_ = 0.0;
};

}  // namespace

void StepGenerator::record_step(std::uint32_t c, double t, int dir, std::vector<Step>& out) {
  State& st = state_[c];
  StepperStats& stats = stats_[c];
  st.n += dir;
  const double interval = t - st.last_step_s;
  if (interval < stats.min_interval_s) {
    stats.min_interval_s = interval;
    stats.peak_time_s = t;
  }
  st.last_step_s = t;
  out.push_back(Step{t, c, dir});
  ++stats.steps;
  if (dir > 0) ++stats.steps_positive;
  else ++stats.steps_negative;
  stats.position_steps = st.n;
}

void StepGenerator::stepper_move(std::uint32_t c, const PlannedMove& move, std::vector<Step>& out) {
  const StepperChannel& ch = channels_[c];
  if (!ch.linear()) {
    if (ch.curve != StepperChannel::Curve::none) curve_move(c, move, out);
    else tower_move(c, move, out);
    return;
  }
  State& st = state_[c];
  const auto& r = ch.row;
  const double start = r[0] * move.start_mm[0] + r[1] * move.start_mm[1] +
                       r[2] * move.start_mm[2] + r[3] * move.start_mm[3];
  const double k = r[0] * move.axes_r[0] + r[1] * move.axes_r[1] + r[2] * move.axes_r[2] +
                   r[3] * move.axes_r[3];
  if (!st.started) {
    st.started = true;
    st.origin_mm = start;
    st.last_end_mm = start;
  }
  double base = start + st.offset_mm;
  // A jump between moves (G92, homing): the motor did not move, so the position stays
  // continuous and the offset takes the jump. Round-off between moves is left alone.
  if (std::abs(base - st.last_end_mm) > 1e-9 * (1.0 + std::abs(st.last_end_mm))) {
    st.offset_mm += st.last_end_mm - base;
    base = st.last_end_mm;
  }
  if (piece_count_ == 0 || k == 0.0) return;
  double dummy = 0.0;
  const PathPiece& last = pieces_[piece_count_ - 1];
  const double s_end = horner(last, last.duration_s, dummy);
  const double end = base + k * s_end;
  st.last_end_mm = end;
  const double step = ch.step_distance_mm;
  const double u_end = (end - st.origin_mm) / step;
  const int dir = k > 0.0 ? 1 : -1;
  // Klipper takes a step when the motor is within kLevelToleranceMm of its half-step level
  // (itersolve.c), so a move that ends that close short of a level steps at its end.
  const double reach = kLevelToleranceMm / step;
  std::int64_t n_end = st.n;
  if (dir > 0) {
    n_end = std::max<std::int64_t>(st.n,
                                   static_cast<std::int64_t>(std::floor(u_end + reach + 0.5)));
  } else {
    n_end = std::min<std::int64_t>(st.n,
                                   static_cast<std::int64_t>(std::ceil(u_end - reach - 0.5)));
  }
  if (n_end == st.n) return;
  // The hot loop of every linear motor, kept with its state in locals (the piece walk of
  // PieceCursor and the bookkeeping of record_step, written out: through them this loop ran
  // 16 % slower on BM_StepsBoxbossCoreXY).
  StepperStats& stats = stats_[c];
  std::size_t pi = 0;
  double piece_t0 = move.start_time_s;
  double piece_end_s = horner(pieces_[0], pieces_[0].duration_s, dummy);
  double lo = 0.0;
  const double inv_k = 1.0 / k;
  const std::int64_t count = dir > 0 ? n_end - st.n : st.n - n_end;
  for (std::int64_t i = 0; i < count; ++i) {
    // The half-step level between n and n + dir.
    const double level = static_cast<double>(st.n) + 0.5 * dir;
    const double s_target = (st.origin_mm + level * step - base) * inv_k;
    while (pi + 1 < piece_count_ && s_target > piece_end_s) {
      piece_t0 += pieces_[pi].duration_s;
      ++pi;
      piece_end_s = horner(pieces_[pi], pieces_[pi].duration_s, dummy);
      lo = 0.0;
    }
    lo = solve_crossing_s(pieces_[pi], s_target, lo);
    const double t = piece_t0 + lo;
    st.n += dir;
    const double interval = t - st.last_step_s;
    if (interval < stats.min_interval_s) {
      stats.min_interval_s = interval;
      stats.peak_time_s = t;
    }
    st.last_step_s = t;
    out.push_back(Step{t, c, dir});
  }
  stats.steps += static_cast<std::uint64_t>(count);
  if (dir > 0) stats.steps_positive += static_cast<std::uint64_t>(count);
  else stats.steps_negative += static_cast<std::uint64_t>(count);
  stats.position_steps = st.n;
}

namespace {

// The steps of a motor whose position q(s) (s: path distance) is monotone on each interval
// of `bounds`: the levels n +- 1/2 crossed on each, as for a linear motor, each crossing
// found by safeguarded Newton on g(s) = dir (q(s) - level) with `slope` = q'. Used by the
// delta towers and winch cables (one turning point at most) and by the curve motors (polar,
// rotary arms). St is StepGenerator::State; emit(t, dir) records the step (and moves st.n).
template <class St, class Q, class Slope, class Emit>
void step_monotone_intervals(St& st, std::span<const double> bounds, const Q& q,
                             const Slope& slope, double offset, double step, double s_end,
                             int max_iterations, PieceCursor& cursor, const Emit& emit) {
  for (std::size_t seg = 0; seg + 1 < bounds.size(); ++seg) {
    const double sa = bounds[seg], sb = bounds[seg + 1];
    const double u_end = (q(sb) + offset - st.origin_mm) / step;
    std::int64_t n_end = st.n;
    const double up = std::floor(u_end + 0.5), down = std::ceil(u_end - 0.5);
    if (static_cast<double>(st.n) < up) n_end = static_cast<std::int64_t>(up);
    else if (static_cast<double>(st.n) > down) n_end = static_cast<std::int64_t>(down);
    if (n_end == st.n) continue;
    const int dir = n_end > st.n ? 1 : -1;
    double lo = sa;
    while (st.n != n_end) {
      const double level = st.origin_mm + (static_cast<double>(st.n) + 0.5 * dir) * step - offset;
      double a = lo, b = sb, sv = lo;
      if (dir * (q(a) - level) < 0.0) {
        for (int it = 0; it < max_iterations; ++it) {
          const double g = dir * (q(sv) - level);
          if (g == 0.0) break;
          (g < 0.0 ? a : b) = sv;
          const double d = dir * slope(sv);
          double next = d > 0.0 ? sv - g / d : 0.5 * (a + b);
          if (!(next > a && next < b)) next = 0.5 * (a + b);
          if (std::abs(next - sv) <= 1e-14 * (1.0 + s_end) || b - a <= 1e-13 * (1.0 + s_end)) {
            sv = next;
            break;
          }
          sv = next;
        }
        sv = std::clamp(sv, lo, sb);
      }
      lo = sv;
      emit(std::max(cursor.time_at(sv), st.last_step_s), dir);
    }
  }
}

}  // namespace

void StepGenerator::tower_move(std::uint32_t c, const PlannedMove& move, std::vector<Step>& out) {
  const StepperChannel& ch = channels_[c];
  State& st = state_[c];
  const double ax = move.axes_r[0], ay = ch.planar ? 0.0 : move.axes_r[1], az = move.axes_r[2];
  // Tool position relative to the tower (x, y) or the anchor (x, y, z) at path distance s.
  const double x0 = move.start_mm[0] - (ch.cable ? ch.anchor_mm[0] : ch.tower_x_mm);
  const double y0 = ch.planar ? 0.0 : move.start_mm[1] - (ch.cable ? ch.anchor_mm[1] : ch.tower_y_mm);
  const double z0 = move.start_mm[2] - (ch.cable ? ch.anchor_mm[2] : 0.0);
  // Delta tower: q(s) = z + sqrt(L^2 - x^2 - y^2), concave; q' = az - (x ax + y ay) / sqrt.
  // Winch cable: q(s) = sqrt(x^2 + y^2 + z^2), convex; q' = (x ax + y ay + z az) / q.
  auto root = [&](double s) {
    const double u = x0 + ax * s, w = y0 + ay * s;
    const double r2 = ch.arm2_mm2 - u * u - w * w;
    if (!(r2 > 0.0)) {
      throw Error(fmt::format("line {}: the effector at X={:.3f} Y={:.3f} is out of reach of {}'s "
                              "rods (the move leaves the delta's build volume)",
                              move.line, u + ch.tower_x_mm, w + ch.tower_y_mm, ch.name));
    }
    return std::sqrt(r2);
  };
  auto length = [&](double s) {
    const double u = x0 + ax * s, w = y0 + ay * s, v = z0 + az * s;
    return std::sqrt(u * u + w * w + v * v);
  };
  auto q = [&](double s) { return ch.cable ? length(s) : z0 + az * s + root(s); };
  auto slope = [&](double s) {
    const double u = x0 + ax * s, w = y0 + ay * s;
    if (ch.cable) {
      const double l = length(s);
      return l > 0.0 ? (u * ax + w * ay + (z0 + az * s) * az) / l : 0.0;
    }
    return az - (u * ax + w * ay) / root(s);
  };
  const double offset = st.continue_at(q(0.0));
  if (piece_count_ == 0 || (ax == 0.0 && ay == 0.0 && az == 0.0)) return;
  double dummy = 0.0;
  const PathPiece& last = pieces_[piece_count_ - 1];
  const double s_end = horner(last, last.duration_s, dummy);
  st.last_end_mm = q(s_end) + offset;
  // q is concave (tower) or convex (cable) in s, so q' is monotone: at most one turning point,
  // where q' changes sign; found by bisection.
  std::array<double, 3> bounds{0.0, s_end, s_end};
  std::size_t segments = 1;
  const double slope0 = slope(0.0), slope1 = slope(s_end);
  if ((slope0 > 0.0 && slope1 < 0.0) || (slope0 < 0.0 && slope1 > 0.0)) {
    double a = 0.0, b = s_end;
    while (b - a > 1e-13 * (1.0 + s_end)) {
      const double mid = 0.5 * (a + b);
      if (mid <= a || mid >= b) break;
      ((slope(mid) > 0.0) == (slope0 > 0.0) ? a : b) = mid;
    }
    bounds = {0.0, 0.5 * (a + b), s_end};
    segments = 2;
  }
  const double step = ch.step_distance_mm;
  PieceCursor cursor(pieces_, piece_count_, move.start_time_s);
  step_monotone_intervals(st, std::span<const double>(bounds.data(), segments + 1), q, slope,
                          offset, step, s_end, 100, cursor,
                          [&](double t, int dir) { record_step(c, t, dir, out); });
}

void StepGenerator::curve_move(std::uint32_t c, const PlannedMove& move, std::vector<Step>& out) {
  using Curve = StepperChannel::Curve;
  const StepperChannel& ch = channels_[c];
  State& st = state_[c];
  const double x0 = move.start_mm[0], y0 = move.start_mm[1], z0 = move.start_mm[2];
  const double ax = move.axes_r[0], ay = move.axes_r[1], az = move.axes_r[2];
  // The polar bed: the angle swept from the start direction, atan2(p0 x p, p0 . p), plus the
  // start's angle. A straight line sweeps less than pi unless it passes through the centre,
  // where the angle jumps by pi (the bed would have to turn at once: every step of the half
  // turn at that instant); a move from the centre keeps the bed still (the angle is constant
  // along the ray), the turn to it is taken as a jump between moves, like G92.
  const double theta0 = std::atan2(y0, x0);
  auto q = [&](double s) -> double {
    const double x = x0 + ax * s, y = y0 + ay * s;
    switch (ch.curve) {
      case Curve::polar_radius: return std::sqrt(x * x + y * y);
      case Curve::polar_angle: return theta0 + std::atan2(x0 * y - y0 * x, x0 * x + y0 * y);
      case Curve::rotary_arm: {
        const double a = ch.rotary->arm_angle_rad(ch.rotary_arm, x, y, z0 + az * s);
        if (!std::isfinite(a)) {
          throw Error(fmt::format("line {}: the effector at X={:.3f} Y={:.3f} Z={:.3f} is out of "
                                  "reach of {}'s arms (the move leaves the rotary delta's build "
                                  "volume)",
                                  move.line, x, y, z0 + az * s, ch.name));
        }
        return a;
      }
      case Curve::none: break;
    }
    return 0.0;
  };
  double dummy = 0.0;
  const double s_end = piece_count_ == 0 ? 0.0
                                         : horner(pieces_[piece_count_ - 1],
                                                  pieces_[piece_count_ - 1].duration_s, dummy);
  auto slope = [&](double s) -> double {
    const double x = x0 + ax * s, y = y0 + ay * s;
    switch (ch.curve) {
      case Curve::polar_radius: {
        const double r = std::sqrt(x * x + y * y);
        return r > 0.0 ? (x * ax + y * ay) / r : 0.0;
      }
      case Curve::polar_angle: {
        const double r2 = x * x + y * y;
        return r2 > 0.0 ? (x * ay - y * ax) / r2 : 0.0;
      }
      default: {
        // Central difference of the arm angle, kept inside the move.
        const double h = 1e-6;
        const double a = std::max(0.0, s - h), b = std::min(s_end, s + h);
        return b > a ? (q(b) - q(a)) / (b - a) : 0.0;
      }
    }
  };
  const double offset = st.continue_at(q(0.0));
  if (piece_count_ == 0 || (ax == 0.0 && ay == 0.0 && az == 0.0)) return;
  if (ch.curve != Curve::rotary_arm && ax == 0.0 && ay == 0.0) return;  // Z only: bed, arm still
  st.last_end_mm = q(s_end) + offset;
  // Monotone pieces: the slope's sign changes found on a grid of the move (the bed angle is
  // monotone along a line; the arm radius is convex: one change; a rotary arm's angle is
  // smooth, 16 intervals per move), each located by bisection.
  std::vector<double> bounds{0.0};
  if (ch.curve != Curve::polar_angle) {
    const int n = ch.curve == Curve::polar_radius ? 1 : 16;
    double prev_s = 0.0, prev_d = slope(0.0);
    for (int i = 1; i <= n; ++i) {
      const double si = s_end * i / n;
      const double di = slope(si);
      if ((prev_d > 0.0 && di < 0.0) || (prev_d < 0.0 && di > 0.0)) {
        double a = prev_s, b = si;
        while (b - a > 1e-13 * (1.0 + s_end)) {
          const double mid = 0.5 * (a + b);
          if (mid <= a || mid >= b) break;
          ((slope(mid) > 0.0) == (prev_d > 0.0) ? a : b) = mid;
        }
        bounds.push_back(0.5 * (a + b));
      }
      if (di != 0.0) {
        prev_s = si;
        prev_d = di;
      }
    }
  }
  bounds.push_back(s_end);
  const double step = ch.step_distance_mm;
  PieceCursor cursor(pieces_, piece_count_, move.start_time_s);
  step_monotone_intervals(st, std::span<const double>(bounds), q, slope, offset, step, s_end, 200,
                          cursor, [&](double t, int dir) { record_step(c, t, dir, out); });
}

// ---------------------------------------------------------------------------------------
// Sink

StepSink::StepSink(std::vector<StepperChannel> channels, Callback on_steps)
    : gen_(std::move(channels)), on_steps_(std::move(on_steps)) {}

void StepSink::consume(const plan::PlanBatch& batch) {
  for (const PlannedMove& m : batch.moves) {
    buf_.clear();
    gen_.add_move(m, buf_);
    if (!buf_.empty() && on_steps_) on_steps_(buf_);
  }
}

// ---------------------------------------------------------------------------------------
// CSV

StepsCsvFile::StepsCsvFile(std::string path, std::vector<std::string> names, OutputOptions options)
    : out_(std::move(path), std::move(options)), names_(std::move(names)) {
  buf_ = "stepper,time_s,direction\n";
  bytes_ = buf_.size();
}

void StepsCsvFile::flush() {
  out_.write(buf_);
  buf_.clear();
}

void StepsCsvFile::write(std::span<const Step> steps) {
  const std::size_t before = buf_.size();
  auto it = std::back_inserter(buf_);
  for (const Step& s : steps) {
    // "{}" is the shortest form that reads back to the same double.
    fmt::format_to(it, "{},{},{}\n", names_[s.stepper], s.time_s, s.direction);
  }
  rows_ += steps.size();
  bytes_ += buf_.size() - before;
  if (buf_.size() > (1u << 20)) flush();
}

void StepsCsvFile::commit() {
  flush();
  out_.commit();
}

// ---------------------------------------------------------------------------------------
// The whole job

std::uint64_t StepsReport::total_steps() const {
  std::uint64_t n = 0;
  for (const StepperStats& s : stats) n += s.steps;
  return n;
}

StepFilter step_filter_from_string(std::string_view name, std::string_view flag) {
  if (name == "none") return StepFilter::none;
  if (name == "klipper") return StepFilter::klipper;
  throw Error(fmt::format("{} '{}': expected none or klipper", flag, name));
}

const char* to_string(StepFilter f) { return f == StepFilter::klipper ? "klipper" : "none"; }

StepsReport generate_steps_file(const std::string& gcode_path, const machine::Machine& m,
                                const std::string& csv_path, StepFilter filter,
                                const LargeCsvCallback& on_large_csv) {
  std::vector<StepperChannel> channels = stepper_channels(m);
  std::vector<std::string> names;
  for (const StepperChannel& c : channels) names.push_back(c.name);
  plan::PlanSource source(gcode_path, m);
  std::unique_ptr<StepsCsvFile> csv;
  if (!csv_path.empty()) csv = std::make_unique<StepsCsvFile>(csv_path, names, OutputOptions{"--csv", {gcode_path}, {}});
  std::uint64_t moves = 0;
  StepDirFilter sds(channels.size());
  std::vector<Step> passed;
  StepRateMeter rates(channels.size());
  bool warned = false;
  StepSink sink(channels, [&](std::span<const Step> steps) {
    rates.push(steps);
    if (filter == StepFilter::klipper) {
      passed.clear();
      sds.push(steps, passed);
      steps = passed;
    }
    if (csv) {
      csv->write(steps);
      if (!warned && on_large_csv && csv->bytes() >= kLargeStepsCsvBytes && !steps.empty()) {
        warned = true;
        on_large_csv(csv->bytes(), steps.back().time_s);
      }
    }
  });
  plan::CallbackSink counter([&](const PlannedMove&) { ++moves; });
  plan::Sink* sinks[] = {&sink, &counter};
  const plan::StreamSummary& summary = plan::run_pipeline(source, sinks);
  if (filter == StepFilter::klipper) {
    passed.clear();
    sds.finish(passed);
    if (csv) csv->write(passed);
  }
  rates.finish();
  if (csv) csv->commit();
  StepsReport r;
  r.rates = rates.figures();
  r.sustained_window_s = rates.window_s();
  r.csv_bytes = csv ? csv->bytes() : 0;
  r.file = gcode_path;
  r.machine_name = m.name;
  r.kinematics = std::string(machine::to_string(m.kinematics));
  r.csv_path = csv_path;
  r.print_time_s = summary.end_time_s;
  r.moves = moves;
  r.channels = sink.generator().channels();
  r.step_filter = filter;
  if (filter == StepFilter::klipper) {
    r.stats = sds.stats();
    r.filtered_pairs = sds.pairs_removed();
  } else {
    r.stats = sink.generator().stats();
    r.filtered_pairs.assign(channels.size(), 0);
  }
  return r;
}

Json to_json(const StepsReport& r) {
  Json steppers = Json::array();
  for (std::size_t i = 0; i < r.channels.size(); ++i) {
    const StepperStats& s = r.stats[i];
    const bool has_pair = std::isfinite(s.min_interval_s);
    steppers.push_back(Json{
        {"name", r.channels[i].name},
        {"step_distance_mm", json_number(r.channels[i].step_distance_mm)},
        {"steps", s.steps},
        {"steps_positive", s.steps_positive},
        {"steps_negative", s.steps_negative},
        {"final_position_steps", s.position_steps},
        {"min_interval_s", has_pair ? json_number(s.min_interval_s) : Json(nullptr)},
        {"peak_step_rate_steps_s",
         has_pair ? json_number(s.peak_step_rate_steps_s()) : Json(nullptr)},
        {"peak_time_s", has_pair ? json_number(s.peak_time_s) : Json(nullptr)},
        {"filtered_pairs", i < r.filtered_pairs.size() ? r.filtered_pairs[i] : 0},
    });
    if (i < r.rates.size()) {
      const StepRateFigures& f = r.rates[i];
      const bool has_filtered_pair = std::isfinite(f.filtered_min_interval_s);
      Json& j = steppers.back();
      j["filtered_peak_step_rate_steps_s"] =
          has_filtered_pair ? json_number(f.filtered_peak_step_rate_steps_s()) : Json(nullptr);
      j["filtered_peak_time_s"] =
          has_filtered_pair ? json_number(f.filtered_peak_time_s) : Json(nullptr);
      j["sustained_step_rate_steps_s"] = json_number(f.sustained_step_rate_steps_s);
      j["sustained_time_s"] =
          std::isfinite(f.sustained_time_s) ? json_number(f.sustained_time_s) : Json(nullptr);
    }
  }
  return Json{{"file", r.file},
              {"machine", r.machine_name},
              {"step_filter", to_string(r.step_filter)},
              {"kinematics", r.kinematics},
              {"csv", r.csv_path.empty() ? Json(nullptr) : Json(r.csv_path)},
              {"print_time_s", json_number(r.print_time_s)},
              {"moves", r.moves},
              {"total_steps", r.total_steps()},
              {"sustained_window_s", json_number(r.sustained_window_s)},
              {"csv_bytes", r.csv_path.empty() ? Json(nullptr) : Json(r.csv_bytes)},
              {"steppers", steppers}};
}

}  // namespace amctl::steppers
