// The plant engine (plant.hpp).
#include "amctl/dynamics/plant.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "amctl/core/error.hpp"

namespace amctl::dynamics {

ModalPlant::ModalPlant(const AxisModel& m0, const AxisModel& m1, double step_s) {
  for (int axis = 0; axis < 2; ++axis) {
    for (const Mode& mode : (axis == 0 ? m0 : m1).modes()) {
      Run r;
      r.axis = axis;
      r.mode = mode;
      r.step = mode_propagator(mode, step_s, kMaxInputTerms);
      runs_.push_back(r);
    }
  }
  sub_.resize(runs_.size());
}

std::vector<int> ModalPlant::mode_axes() const {
  std::vector<int> a;
  a.reserve(runs_.size());
  for (const Run& r : runs_) a.push_back(r.axis);
  return a;
}

void ModalPlant::apply(const ModePropagator* props, int terms, const InputTerms& u) {
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    Run& run = runs_[r];
    const ModePropagator& p = props ? props[r] : run.step;
    double e = p.phi[0][0] * run.e + p.phi[0][1] * run.q;
    double q = p.phi[1][0] * run.e + p.phi[1][1] * run.q;
    const double* ua = u[run.axis];
    for (int j = 0; j < terms; ++j) {
      e += p.psi[0][j] * ua[j];
      q += p.psi[1][j] * ua[j];
    }
    run.e = e;
    run.q = q;
  }
}

void ModalPlant::step(int terms, const InputTerms& u) { apply(nullptr, terms, u); }

void ModalPlant::advance(double tau, int terms, const InputTerms& u) {
  const int nt = std::max(1, terms);
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    const Mode& md = runs_[r].mode;
    const bool same = r > 0 && md.natural_frequency_hz == runs_[r - 1].mode.natural_frequency_hz &&
                      md.damping_ratio == runs_[r - 1].mode.damping_ratio &&
                      md.participation == runs_[r - 1].mode.participation;
    sub_[r] = same ? sub_[r - 1] : mode_propagator(md, tau, nt);
  }
  apply(sub_.data(), terms, u);
}

void ModalPlant::velocity_jump(double dv0, double dv1) {
  if (dv0 == 0.0 && dv1 == 0.0) return;
  // A jump dv of the commanded velocity is an impulse of commanded acceleration: the carriage
  // velocity x' stays continuous, so e' = x' - x_b' jumps by -g dv, i.e. q = e'/w by -g dv / w.
  for (Run& r : runs_) {
    const double w = 2.0 * std::numbers::pi * r.mode.natural_frequency_hz;
    r.q -= r.mode.participation * (r.axis == 0 ? dv0 : dv1) / w;
  }
}

std::array<double, 2> ModalPlant::deflection_mm() const {
  double err[2] = {0.0, 0.0};
  for (const Run& r : runs_) err[r.axis] += r.e;
  return {err[0], err[1]};
}

std::array<double, 2> ModalPlant::vibration_mm(int terms, const InputTerms& u) const {
  double vib2[2] = {0.0, 0.0};
  for (const Run& r : runs_) {
    double pe = 0.0, pq = 0.0;
    if (terms > 0) {
      pe = r.step.pi[0][0] * u[r.axis][0];
      pq = r.step.pi[1][0] * u[r.axis][0];
    }
    vib2[r.axis] += (r.e - pe) * (r.e - pe) + (r.q - pq) * (r.q - pq);
  }
  return {std::sqrt(vib2[0]), std::sqrt(vib2[1])};
}

void ModalPlant::modal_state(int terms, const InputTerms& u, std::span<double> out) const {
  AMCTL_CHECK(out.size() >= 2 * runs_.size(), "modal_state: output too short");
  for (std::size_t r = 0; r < runs_.size(); ++r) {
    const Run& rr = runs_[r];
    const double a = terms > 0 ? u[rr.axis][0] : 0.0;
    out[2 * r] = rr.e - rr.step.pi[0][0] * a;
    out[2 * r + 1] = rr.q - rr.step.pi[1][0] * a;
  }
}

// ------------------------------------------------------------------------- PieceSimulator

PieceSimulator::PieceSimulator(const AxisModel& m0, const AxisModel& m1, double rate_hz, double grid_t0,
                               long long grid_index0)
    : plant_((require_above_nyquist(rate_hz, {&m0, &m1}), m0), m1, 1.0 / rate_hz),
      h_(1.0 / rate_hz),
      grid_t0_(grid_t0),
      grid_index0_(grid_index0) {
  require_finite("grid_t0_s", grid_t0);
}

namespace {
// The highest degree with a non-zero coefficient on either axis.
int piece_degree(const CommandPiece& p) {
  for (int k = kCommandPieceCoeffs - 1; k > 0; --k) {
    if (p.c[0][static_cast<std::size_t>(k)] != 0.0 || p.c[1][static_cast<std::size_t>(k)] != 0.0) return k;
  }
  return 0;
}
}  // namespace

void PieceSimulator::load(const CommandPiece& p, double tau, PlantSample& s) {
  const int deg = piece_degree(p);
  terms_ = std::max(0, deg - 1);
  for (std::size_t a = 0; a < 2; ++a) {
    // Taylor coefficients at tau (repeated synthetic division): b_m = p^(m)(tau) / m!.
    std::array<double, kCommandPieceCoeffs> b = p.c[a];
    for (int m = 0; m <= deg; ++m) {
      for (int k = deg - 1; k >= m; --k) b[static_cast<std::size_t>(k)] += tau * b[static_cast<std::size_t>(k + 1)];
    }
    s.cmd_mm[a] = b[0];
    double fact = 2.0;  // (j + 2)!
    for (int j = 0; j < kMaxInputTerms; ++j) {
      u_[a][j] = j < terms_ ? fact * b[static_cast<std::size_t>(j + 2)] : 0.0;
      fact *= static_cast<double>(j + 3);
    }
  }
}

void PieceSimulator::push(const CommandPiece& p, const Sink& sink) {
  require_finite("command piece start", p.t0_s);
  if (!(p.duration_s >= 0.0) || !std::isfinite(p.duration_s)) {
    throw Error("a command piece's duration must be finite and >= 0");
  }
  ++pieces_;
  PlantSample s;
  if (!started_) {
    started_ = true;
    t_ = p.t0_s;
    // Samples before the first piece: at rest on its start.
    terms_ = 0;
    for (auto& ua : u_) std::fill(std::begin(ua), std::end(ua), 0.0);
    for (;; ++k_) {
      const double tk = time(k_);
      if (tk >= p.t0_s - 1e-12 * std::max(1.0, std::abs(tk))) break;
      s.t_s = tk;
      s.cmd_mm = {p.c[0][0], p.c[1][0]};
      s.sim_mm = s.cmd_mm;
      sink(s);
    }
  }
  // The command's velocity jumps from the last piece's end (from rest before the first).
  plant_.velocity_jump(p.c[0][1] - end_vel_[0], p.c[1][1] - end_vel_[1]);
  const double t_end = p.t0_s + p.duration_s;
  PlantSample at;
  for (;; ++k_) {
    const double tk = time(k_);
    const double tol = 1e-12 * std::max(1.0, std::abs(tk));
    if (tk >= t_end - tol) break;
    if (tk > t_ + tol) {
      load(p, t_ - p.t0_s, at);
      const double dt = tk - t_;
      if (std::abs(dt - h_) <= tol) {
        plant_.step(terms_, u_);
      } else {
        plant_.advance(dt, terms_, u_);
      }
      updates_ += plant_.modes();
    }
    t_ = std::max(t_, tk);  // within round-off of a sample: the state is taken as there
    s.t_s = tk;
    load(p, tk - p.t0_s, s);
    const auto d = plant_.deflection_mm();
    s.sim_mm = {s.cmd_mm[0] + d[0], s.cmd_mm[1] + d[1]};
    sink(s);
  }
  const double tol_end = 1e-12 * std::max(1.0, std::abs(t_end));
  if (t_end > t_ + tol_end) {
    load(p, t_ - p.t0_s, at);
    const double dt = t_end - t_;
    if (std::abs(dt - h_) <= tol_end) {
      plant_.step(terms_, u_);  // a piece one output step long, starting on a sample
    } else {
      plant_.advance(dt, terms_, u_);
    }
    updates_ += plant_.modes();
  }
  t_ = std::max(t_, t_end);
  // The command at the piece's end (Horner) and its velocity.
  for (std::size_t a = 0; a < 2; ++a) {
    double x = 0.0, v = 0.0;
    for (int k = kCommandPieceCoeffs - 1; k >= 0; --k) {
      x = x * p.duration_s + p.c[a][static_cast<std::size_t>(k)];
      if (k >= 1) v = v * p.duration_s + static_cast<double>(k) * p.c[a][static_cast<std::size_t>(k)];
    }
    end_pos_[a] = x;
    end_vel_[a] = v;
  }
}

void PieceSimulator::rest_until(std::size_t last_k, const Sink& sink) {
  plant_.velocity_jump(-end_vel_[0], -end_vel_[1]);
  end_vel_ = {0.0, 0.0};
  terms_ = 0;
  for (auto& ua : u_) std::fill(std::begin(ua), std::end(ua), 0.0);
  PlantSample s;
  for (; k_ <= last_k; ++k_) {
    const double tk = time(k_);
    const double tol = 1e-12 * std::max(1.0, std::abs(tk));
    if (tk > t_ + tol) {
      const double dt = tk - t_;
      if (std::abs(dt - h_) <= tol) {
        plant_.step(0, u_);
      } else {
        plant_.advance(dt, 0, u_);
      }
      updates_ += plant_.modes();
    }
    t_ = std::max(t_, tk);
    s.t_s = tk;
    s.cmd_mm = end_pos_;
    const auto d = plant_.deflection_mm();
    s.sim_mm = {end_pos_[0] + d[0], end_pos_[1] + d[1]};
    sink(s);
  }
}

}  // namespace amctl::dynamics
