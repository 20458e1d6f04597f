// Step generation on the shaped plan (shaped_steps.hpp, docs/steppers.md "Input shaping").
#include "amctl/steppers/shaped_steps.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"
#include "amctl/shaping/shaper.hpp"

namespace amctl::steppers {

using shaping::AxisPiece;

namespace {

constexpr int kMaxDegree = shaping::kAxisPieceCoeffs - 1;

double peval(const double* c, int deg, double x) {
  double v = 0.0;
  for (int k = deg; k >= 0; --k) v = v * x + c[k];
  return v;
}

double peval_d(const double* c, int deg, double x, double& d) {
  double v = 0.0, dv = 0.0;
  for (int k = deg; k >= 0; --k) {
    dv = dv * x + v;
    v = v * x + c[k];
  }
  d = dv;
  return v;
}

/// The root of c in [a, b] where it changes sign (fa = c(a), fa * c(b) < 0): safeguarded
/// Newton from x (in (a, b); the midpoint when it is not), to round-off.
double bracket_root(const double* c, int deg, double a, double b, double fa, double x) {
  if (!(x > a && x < b)) x = 0.5 * (a + b);
  for (int it = 0; it < 200; ++it) {
    double d = 0.0;
    const double f = peval_d(c, deg, x, d);
    if (f == 0.0) return x;
    if ((f < 0.0) == (fa < 0.0)) a = x;
    else b = x;
    double nx = d != 0.0 ? x - f / d : 0.5 * (a + b);
    if (!(nx > a && nx < b)) nx = 0.5 * (a + b);
    if (std::abs(nx - x) <= 1e-15 * (1.0 + std::abs(x)) ||
        b - a <= 1e-15 * (1.0 + std::abs(a) + std::abs(b))) {
      return nx;
    }
    x = nx;
  }
  return x;
}

void roots_rec(const double* c, int deg, double a, double b, double* out, int& n) {
  while (deg > 0 && c[deg] == 0.0) --deg;
  if (deg <= 0) return;
  if (deg == 1) {
    const double r = -c[0] / c[1];
    if (r > a && r < b) out[n++] = r;
    return;
  }
  if (deg == 2) {
    const double disc = c[1] * c[1] - 4.0 * c[2] * c[0];
    if (disc < 0.0) return;
    const double q = -0.5 * (c[1] + std::copysign(std::sqrt(disc), c[1]));
    double r1 = q / c[2];
    double r2 = q != 0.0 ? c[0] / q : r1;
    if (r1 > r2) std::swap(r1, r2);
    if (r1 > a && r1 < b) out[n++] = r1;
    if (r2 > a && r2 < b && r2 != r1) out[n++] = r2;
    return;
  }
  double d[kMaxDegree + 1];
  for (int k = 0; k < deg; ++k) d[k] = (k + 1) * c[k + 1];
  double crit[kMaxDegree + 2];
  int m = 0;
  roots_rec(d, deg - 1, a, b, crit, m);
  double x = a, fx = peval(c, deg, a);
  for (int i = 0; i <= m; ++i) {
    const double y = i < m ? crit[i] : b;
    const double fy = peval(c, deg, y);
    if (fx == 0.0 && x > a) out[n++] = x;
    else if ((fx < 0.0 && fy > 0.0) || (fx > 0.0 && fy < 0.0)) {
      out[n++] = bracket_root(c, deg, x, y, fx, 0.5 * (x + y));
    }
    x = y;
    fx = fy;
  }
}

/// tau in [lo, b] where the polynomial (monotone there, in direction dir) reaches `level`;
/// pb = p(b).
double crossing(const double* p, int deg, double lo, double b, double pb, double level, int dir) {
  double tau = lo;
  if (deg <= 0) return lo;
  if (deg == 1) {
    if (p[1] != 0.0) tau = (level - p[0]) / p[1];
  } else if (deg == 2) {
    // At lo: g(s) = A s^2 + B s - D with B = dir q'(lo) >= 0 and D = dir (level - q(lo)):
    // s = 2D / (B + sqrt(B^2 + 4 A D)), free of cancellation for both signs of A.
    const double v0 = p[0] + lo * (p[1] + lo * p[2]);
    const double v1 = p[1] + 2.0 * lo * p[2];
    const double D = dir * (level - v0);
    const double B = dir * v1, A = dir * p[2];
    const double den = B + std::sqrt(std::max(0.0, B * B + 4.0 * A * D));
    tau = den > 0.0 ? lo + 2.0 * D / den : lo;
  } else {
    double g[kMaxDegree + 1];
    for (int k = 0; k <= deg; ++k) g[k] = p[k];
    g[0] -= level;
    // g, g' and g''/2 at lo in one Horner pass.
    double ga = 0.0, g1 = 0.0, g2 = 0.0;
    for (int k = deg; k >= 0; --k) {
      g2 = g2 * lo + g1;
      g1 = g1 * lo + ga;
      ga = ga * lo + g[k];
    }
    if (dir * ga >= 0.0) return lo;
    if (dir * (pb - level) <= 0.0) return b;
    // Steps are close together: the root of g's quadratic Taylor polynomial at lo (the
    // cancellation-free form of the degree-2 case) starts Newton next to the root.
    const double B = dir * g1, A = dir * g2, D = -dir * ga;
    const double den = B + std::sqrt(std::max(0.0, B * B + 4.0 * A * D));
    tau = bracket_root(g, deg, lo, b, ga, den > 0.0 ? lo + 2.0 * D / den : b);
  }
  return std::clamp(tau, lo, b);
}

}  // namespace

namespace detail {
void real_roots(const double* c, int degree, double a, double b, std::vector<double>& out) {
  AMCTL_CHECK(degree <= kMaxDegree, "polynomial degree at most 8");
  double r[kMaxDegree + 2];
  int n = 0;
  roots_rec(c, degree, a, b, r, n);
  out.insert(out.end(), r, r + n);
}
}  // namespace detail

shaping::AxisShapers axis_shapers(const machine::InputShaper& config) {
  shaping::AxisShapers s;
  if (config.shaper_freq_x_hz > 0.0) {
    s.xyz[0] = shaping::make_shaper(config.shaper_type_x, config.shaper_freq_x_hz,
                                    config.damping_ratio_x);
  }
  if (config.shaper_freq_y_hz > 0.0) {
    s.xyz[1] = shaping::make_shaper(config.shaper_type_y, config.shaper_freq_y_hz,
                                    config.damping_ratio_y);
  }
  if (config.shaper_freq_z_hz > 0.0) {
    s.xyz[2] = shaping::make_shaper(config.shaper_type_z, config.shaper_freq_z_hz,
                                    config.damping_ratio_z);
  }
  return s;
}

shaping::PressureAdvance pressure_advance(const machine::Machine& m) {
  if (!m.extruder.present) return {};
  return shaping::PressureAdvance{m.extruder.pressure_advance_s,
                                  m.extruder.pressure_advance_smooth_time_s};
}

ShapedStepGenerator::ShapedStepGenerator(std::vector<kinematics::Motor> motors,
                                         const shaping::AxisShapers& shapers,
                                         const shaping::PressureAdvance& pa)
    : motors_(std::move(motors)),
      state_(motors_.size()),
      stats_(motors_.size()),
      stream_(shapers, pa),
      scratch_(motors_.size()) {
  for (const kinematics::Motor& m : motors_) {
    AMCTL_CHECK(m.step_distance.value > 0.0, "step distance must be positive");
    AMCTL_CHECK(!m.linear() || m.row[3] == 0.0 || (m.row[0] == 0.0 && m.row[1] == 0.0 && m.row[2] == 0.0),
                "a motor moves with the toolhead or with the extruder, not both");
  }
  make_streams(shapers, pa);
}

void ShapedStepGenerator::make_streams(const shaping::AxisShapers& shapers,
                                       const shaping::PressureAdvance& pa) {
  // With pressure advance the extruder is stepped on pieces of its own: the toolhead's pieces
  // break at every plan break shifted by each shaper delay, the extruder's by -h, 0 and +h;
  // one stream for both would give every motor the breaks of both.
  e_stream_.reset();
  if (pa.active()) {
    stream_ = shaping::ShapedPieceStream(shapers, shaping::PressureAdvance{0.0, pa.smooth_time_s});
    e_stream_.emplace(shaping::AxisShapers{}, pa);
  } else {
    stream_ = shaping::ShapedPieceStream(shapers, pa);
  }
  front_s_ = e_front_s_ = -std::numeric_limits<double>::infinity();
}

bool ShapedStepGenerator::on_extruder_stream(std::size_t c) const {
  return e_stream_.has_value() && motors_[c].linear() && motors_[c].row[3] != 0.0;
}

void ShapedStepGenerator::set_advance(double advance_s) {
  if (e_stream_) e_stream_->set_advance(advance_s);
  else stream_.set_advance(advance_s);
}

void ShapedStepGenerator::add_move(const plan::PlannedMove& move, std::vector<Step>& out) {
  pieces_.clear();
  stream_.push(move, pieces_);
  e_pieces_.clear();
  if (e_stream_) e_stream_->push(move, e_pieces_);
  step_pieces(out, false);
}

double ShapedStepGenerator::motor_position(std::size_t c, const std::array<double, 4>& x) const {
  const kinematics::Motor& m = motors_[c];
  if (m.linear()) return m.row[0] * x[0] + m.row[1] * x[1] + m.row[2] * x[2] + m.row[3] * x[3];
  return m.curve->position(kinematics::Vec3{x[0], x[1], x[2]});
}

void ShapedStepGenerator::reconfigure(const shaping::AxisShapers& shapers,
                                      const shaping::PressureAdvance& pa, std::vector<Step>& out) {
  if (stream_.started()) {
    finish(out);
    for (std::size_t c = 0; c < motors_.size(); ++c) {
      State& st = state_[c];
      if (!st.started) continue;
      st.resume = true;
      st.resume_mm = motor_position(c, stream_.end_mm()) - st.origin;
    }
  }
  make_streams(shapers, pa);
}

void ShapedStepGenerator::continue_from(const StepGenerator& plain) {
  for (std::size_t c = 0; c < motors_.size(); ++c) {
    const StepGenerator::MotorState p = plain.motor_state(c);
    if (!p.started) continue;
    State& st = state_[c];
    st.started = true;
    st.resume = true;
    st.resume_mm = p.last_end_mm - p.origin_mm;
    st.n = p.n;
    st.last_step_s = p.last_step_s;
  }
  stats_ = plain.stats();
}

void ShapedStepGenerator::finish(std::vector<Step>& out) {
  pieces_.clear();
  stream_.finish(pieces_);
  e_pieces_.clear();
  if (e_stream_) e_stream_->finish(e_pieces_);
  step_pieces(out, true);
}

void ShapedStepGenerator::record(std::uint32_t c, double t, int dir) {
  State& st = state_[c];
  StepperStats& stats = stats_[c];
  t = std::max(t, st.last_step_s);
  // A level touched at a turning point (or where two pieces meet) can give a step and its step
  // back at one instant, a root-finding artefact rather than motion: the two cancel. (Within
  // 1 ns no motor reverses; Klipper's filter would drop the pair anyway.)
  constexpr double kSameInstantS = 1e-9;
  std::vector<Step>& mine = scratch_[c];
  if (!mine.empty() && mine.back().direction == -dir && t - st.last_step_s <= kSameInstantS) {
    mine.pop_back();
    st.n += dir;
    --stats.steps;
    if (dir < 0) --stats.steps_positive;
    else --stats.steps_negative;
    st.last_step_s = st.before_last_step_s;
    stats.min_interval_s = st.before_min_interval_s;
    stats.peak_time_s = st.before_peak_time_s;
    stats.position_steps = st.n;
    return;
  }
  st.before_last_step_s = st.last_step_s;
  st.before_min_interval_s = stats.min_interval_s;
  st.before_peak_time_s = stats.peak_time_s;
  st.n += dir;
  const double interval = t - st.last_step_s;
  if (interval < stats.min_interval_s) {
    stats.min_interval_s = interval;
    stats.peak_time_s = t;
  }
  st.last_step_s = t;
  scratch_[c].push_back(Step{t, c, dir});
  ++stats.steps;
  if (dir > 0) ++stats.steps_positive;
  else ++stats.steps_negative;
  stats.position_steps = st.n;
}

void ShapedStepGenerator::step_pieces(std::vector<Step>& out, bool final) {
  if (pieces_.empty() && e_pieces_.empty() && !final) return;
  for (const AxisPiece& piece : pieces_) {
    for (std::uint32_t c = 0; c < motors_.size(); ++c) {
      if (on_extruder_stream(c)) continue;
      if (motors_[c].linear()) linear_piece(c, piece);
      else curve_piece(c, piece);
    }
  }
  for (const AxisPiece& piece : e_pieces_) {
    for (std::uint32_t c = 0; c < motors_.size(); ++c) {
      if (on_extruder_stream(c)) linear_piece(c, piece);
    }
  }
  if (!pieces_.empty()) front_s_ = pieces_.back().t0_s + pieces_.back().duration_s;
  if (!e_pieces_.empty()) e_front_s_ = e_pieces_.back().t0_s + e_pieces_.back().duration_s;
  // Steps go out in time order: with two streams, only those before both streams' ends (the
  // rest wait for the other stream's next pieces).
  const double release = final || !e_stream_ ? std::numeric_limits<double>::infinity()
                                             : std::min(front_s_, e_front_s_);
  // Merge by time, ties in motor order: each motor's released steps merged into the motors'
  // before it (std::merge takes the first range's element first on a tie).
  const auto by_time = [](const Step& a, const Step& b) { return a.time_s < b.time_s; };
  merged_.clear();
  for (std::size_t c = 0; c < motors_.size(); ++c) {
    std::vector<Step>& s = scratch_[c];
    const auto end = release == std::numeric_limits<double>::infinity()
                         ? s.end()
                         : std::upper_bound(s.begin(), s.end(), Step{release, 0, 0}, by_time);
    if (end == s.begin()) continue;
    if (merged_.empty()) {
      merged_.assign(s.begin(), end);
    } else {
      merge_tmp_.resize(merged_.size() + static_cast<std::size_t>(end - s.begin()));
      std::merge(merged_.begin(), merged_.end(), s.begin(), end, merge_tmp_.begin(), by_time);
      merged_.swap(merge_tmp_);
    }
    s.erase(s.begin(), end);
  }
  out.insert(out.end(), merged_.begin(), merged_.end());
}

void ShapedStepGenerator::linear_piece(std::uint32_t c, const AxisPiece& piece) {
  const kinematics::Motor& motor = motors_[c];
  State& st = state_[c];
  const auto& r = motor.row;
  double p[kMaxDegree + 1] = {};
  int deg = 0;
  for (int k = 0; k <= piece.degree; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    p[k] = r[0] * piece.c[0][kk] + r[1] * piece.c[1][kk] + r[2] * piece.c[2][kk] +
           r[3] * piece.c[3][kk];
    if (k > 0 && p[k] != 0.0) deg = k;
  }
  if (!st.started || st.resume) {
    st.origin = p[0] - (st.resume ? st.resume_mm : 0.0);
    st.started = true;
    st.resume = false;
  }
  if (deg == 0) return;
  const double L = piece.duration_s;
  const double step = motor.step_distance.value;
  {
    // Most shaped pieces are short: when the motor cannot reach the next half-step level
    // either way (|p(tau) - p(0)| <= sum |c_k| L^k), it takes no step on this piece.
    double reach = 0.0, Lk = 1.0;
    for (int k = 1; k <= deg; ++k) {
      Lk *= L;
      reach += std::abs(p[k]) * Lk;
    }
    const double at0 = (p[0] - st.origin) / step, span = reach / step;
    const double n = static_cast<double>(st.n), margin = 1e-6;
    if (at0 + span + margin < n + 0.5 && at0 - span - margin > n - 0.5) return;
  }
  bounds_.assign(1, 0.0);
  double d[kMaxDegree];
  for (int k = 0; k < deg; ++k) d[k] = (k + 1) * p[k + 1];
  detail::real_roots(d, deg - 1, 0.0, L, bounds_);
  bounds_.push_back(L);
  for (std::size_t i = 0; i + 1 < bounds_.size(); ++i) {
    const double a = bounds_[i], b = bounds_[i + 1];
    const double pb = peval(p, deg, b);
    const double ub = (pb - st.origin) / step;
    double lo = a;
    while (static_cast<double>(st.n) + 0.5 <= ub) {
      const double level = st.origin + (static_cast<double>(st.n) + 0.5) * step;
      lo = crossing(p, deg, lo, b, pb, level, 1);
      record(c, piece.t0_s + lo, 1);
    }
    while (static_cast<double>(st.n) - 0.5 >= ub) {
      const double level = st.origin + (static_cast<double>(st.n) - 0.5) * step;
      lo = crossing(p, deg, lo, b, pb, level, -1);
      record(c, piece.t0_s + lo, -1);
    }
  }
}

void ShapedStepGenerator::curve_piece(std::uint32_t c, const AxisPiece& piece) {
  const kinematics::Motor& motor = motors_[c];
  const kinematics::MotorCurve& curve = *motor.curve;
  State& st = state_[c];
  const int deg = piece.degree;
  auto point = [&](double tau) {
    return kinematics::Vec3{peval(piece.c[0].data(), deg, tau), peval(piece.c[1].data(), deg, tau),
                            peval(piece.c[2].data(), deg, tau)};
  };
  auto q = [&](double tau) {
    const kinematics::Vec3 pt = point(tau);
    const double v = curve.position(pt);
    if (!std::isfinite(v)) {
      throw Error(fmt::format("line {}: {}", piece.line, curve.out_of_reach(pt, motor.name)));
    }
    return v;
  };
  const double q0 = q(0.0);
  if (!st.started || st.resume) {
    st.origin = q0 - (st.resume ? st.resume_mm : 0.0);
    st.started = true;
    st.resume = false;
  }
  bool moves = false;
  for (std::size_t a = 0; a < 3 && !moves; ++a) {
    for (int k = 1; k <= deg; ++k) moves = moves || piece.c[a][static_cast<std::size_t>(k)] != 0.0;
  }
  if (!moves) return;
  const double L = piece.duration_s;
  const int samples = std::max(8, static_cast<int>(std::ceil(L / kCurveSampleS)));
  // Turning points: sign changes of the sampled differences, each refined by bisection on
  // the sign of q(x + h) - q(x - h).
  bounds_.assign(1, 0.0);
  const double dt = L / samples;
  double prev_q = q0;
  int prev_sign = 0;
  for (int j = 1; j <= samples; ++j) {
    const double qj = q(j == samples ? L : j * dt);
    const int sign = qj > prev_q ? 1 : (qj < prev_q ? -1 : 0);
    if (sign != 0 && prev_sign != 0 && sign != prev_sign) {
      double lo = (j - 2) * dt, hi = j * dt;
      const double h = 1e-9 * (1.0 + L);
      for (int it = 0; it < 60 && hi - lo > 1e-13 * (1.0 + L); ++it) {
        const double mid = 0.5 * (lo + hi);
        const double slope = q(std::min(L, mid + h)) - q(std::max(0.0, mid - h));
        if ((slope > 0.0 ? 1 : -1) == prev_sign) lo = mid;
        else hi = mid;
      }
      bounds_.push_back(0.5 * (lo + hi));
    }
    if (sign != 0) prev_sign = sign;
    prev_q = qj;
  }
  bounds_.push_back(L);
  const double step = motor.step_distance.value;
  // Illinois regula falsi on q - level, bracketed on a monotone interval.
  auto solve = [&](double a, double b, double level, int dir) {
    double fa = dir * (q(a) - level), fb = dir * (q(b) - level);
    if (fa >= 0.0) return a;
    if (fb <= 0.0) return b;
    int side = 0;
    double x = a;
    for (int it = 0; it < 200 && b - a > 1e-13 * (1.0 + L); ++it) {
      x = (a * fb - b * fa) / (fb - fa);
      if (!(x > a && x < b)) x = 0.5 * (a + b);
      const double fx = dir * (q(x) - level);
      if (fx == 0.0) return x;
      if (fx < 0.0) {
        a = x;
        fa = fx;
        if (side == -1) fb *= 0.5;
        side = -1;
      } else {
        b = x;
        fb = fx;
        if (side == 1) fa *= 0.5;
        side = 1;
      }
    }
    return x;
  };
  for (std::size_t i = 0; i + 1 < bounds_.size(); ++i) {
    const double a = bounds_[i], b = bounds_[i + 1];
    if (!(b > a)) continue;
    const double ub = (q(b) - st.origin) / step;
    double lo = a;
    while (static_cast<double>(st.n) + 0.5 <= ub) {
      lo = solve(lo, b, st.origin + (static_cast<double>(st.n) + 0.5) * step, 1);
      record(c, piece.t0_s + lo, 1);
    }
    while (static_cast<double>(st.n) - 0.5 >= ub) {
      lo = solve(lo, b, st.origin + (static_cast<double>(st.n) - 0.5) * step, -1);
      record(c, piece.t0_s + lo, -1);
    }
  }
}

ShapedStepSink::ShapedStepSink(std::vector<kinematics::Motor> motors,
                               const shaping::AxisShapers& shapers,
                               const shaping::PressureAdvance& pa, Callback on_steps)
    : gen_(std::move(motors), shapers, pa), on_steps_(std::move(on_steps)) {}

void ShapedStepSink::consume(const plan::PlanBatch& batch) {
  for (const plan::PlannedMove& m : batch.moves) {
    buf_.clear();
    gen_.add_move(m, buf_);
    if (!buf_.empty() && on_steps_) on_steps_(buf_);
  }
}

void ShapedStepSink::finish(const plan::StreamSummary&) {
  buf_.clear();
  gen_.finish(buf_);
  if (!buf_.empty() && on_steps_) on_steps_(buf_);
}

shaping::AxisShapers axis_shapers(const std::array<gcode::AxisShaperSetting, 3>& s) {
  shaping::AxisShapers out;
  for (std::size_t a = 0; a < 3; ++a) {
    if (s[a].freq_hz > 0.0) out.xyz[a] = shaping::make_shaper(s[a].type, s[a].freq_hz, s[a].damping_ratio);
  }
  return out;
}

TunedStepSink::TunedStepSink(std::vector<kinematics::Motor> motors, const machine::Machine& m,
                             Callback on_steps)
    : motors_(std::move(motors)), pa_(pressure_advance(m)), on_steps_(std::move(on_steps)) {
  const machine::InputShaper& is = m.input_shaper;
  shapers_[0] = {is.shaper_type_x, is.shaper_freq_x_hz, is.damping_ratio_x};
  shapers_[1] = {is.shaper_type_y, is.shaper_freq_y_hz, is.damping_ratio_y};
  shapers_[2] = {is.shaper_type_z, is.shaper_freq_z_hz, is.damping_ratio_z};
  if (is.active() || pa_.active()) {
    shaped_.emplace(motors_, axis_shapers(shapers_), pa_);
  } else {
    plain_.emplace(motors_);
  }
}

const std::vector<StepperStats>& TunedStepSink::stats() const {
  return shaped_ ? shaped_->stats() : plain_->stats();
}

void TunedStepSink::on_move(const plan::PlannedMove& m) {
  buf_.clear();
  if (shaped_) {
    shaped_->add_move(m, buf_);
  } else {
    plain_->add_move(m, buf_);
  }
  if (!buf_.empty() && on_steps_) on_steps_(buf_);
}

void TunedStepSink::on_tuning(const plan::PlanEvent& e) {
  const gcode::StepTuningCommand& c = e.tuning;
  const bool advance = c.kind == gcode::StepTuningCommand::Kind::pressure_advance;
  if (advance) {
    if (c.extruder != "extruder") return;  // a stepper amctl does not step
    pa_ = shaping::PressureAdvance{c.pressure_advance_s, c.smooth_time_s};
    if (!c.flush) {
      if (shaped_) shaped_->set_advance(c.pressure_advance_s);
      return;
    }
  } else {
    shapers_ = c.shapers;
  }
  buf_.clear();
  const shaping::AxisShapers shapers = axis_shapers(shapers_);
  if (shaped_) {
    shaped_->reconfigure(shapers, pa_, buf_);
  } else {
    bool any = pa_.active();
    for (const auto& s : shapers.xyz) any = any || s.has_value();
    if (!any) return;
    shaped_.emplace(motors_, shapers, pa_);
    shaped_->continue_from(*plain_);
  }
  if (!buf_.empty() && on_steps_) on_steps_(buf_);
}

void TunedStepSink::consume(const plan::PlanBatch& batch) {
  plan::for_each_in_order(
      batch, [&](const plan::PlannedMove& m) { on_move(m); },
      [&](const plan::PlanEvent& e) {
        if (e.kind == plan::PlanEvent::Kind::step_tuning) on_tuning(e);
      });
}

void TunedStepSink::finish(const plan::StreamSummary&) {
  if (!shaped_) return;
  buf_.clear();
  shaped_->finish(buf_);
  if (!buf_.empty() && on_steps_) on_steps_(buf_);
}

}  // namespace amctl::steppers
