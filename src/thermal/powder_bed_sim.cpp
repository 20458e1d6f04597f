#include "amctl/thermal/powder_bed_sim.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "amctl/core/error.hpp"

namespace amctl::thermal {

const char* to_string(TimeScheme s) {
  switch (s) {
    case TimeScheme::crank_nicolson: return "crank_nicolson";
    case TimeScheme::bdf2: return "bdf2";
    case TimeScheme::tr_bdf2: return "tr_bdf2";
    case TimeScheme::backward_euler: return "backward_euler";
  }
  return "?";
}

HeatColumn::HeatColumn(const PowderMaterial& material, double cell_m, int cells,
                       double initial_temp_c, TimeScheme scheme, int rannacher_half_steps,
                       Coarsening coarsening)
    : material_(material), cell_m_(cell_m), scheme_(scheme),
      rannacher_half_steps_(rannacher_half_steps), coarsening_(coarsening) {
  material_.validate();
  require_positive("cell size (layer thickness / cells_per_layer), m", cell_m);
  if (cells < 1) throw Error("heat column needs at least one cell, got " + std::to_string(cells));
  require_finite("initial temperature, C", initial_temp_c);
  if (rannacher_half_steps < 0)
    throw Error("rannacher_half_steps must be >= 0, got " + std::to_string(rannacher_half_steps));
  if (coarsening_.enabled) {
    require_positive("coarsening min_depth_m", coarsening_.min_depth_m);
    require_positive("coarsening grading", coarsening_.grading);
  }
  d_.assign(std::size_t(cells), cell_m);
  t_.assign(std::size_t(cells) + 1, initial_temp_c);
  rebuild_mesh();
  coarsen();
}

void HeatColumn::rebuild_mesh() {
  const std::size_t n = d_.size() + 1;
  const double a2 = material_.diffusivity_m2_s();
  cap_.assign(n, 0.0);
  g_.resize(d_.size());
  length_m_ = 0.0;
  for (std::size_t j = 0; j < d_.size(); ++j) {
    cap_[j] += 0.5 * d_[j];
    cap_[j + 1] += 0.5 * d_[j];
    g_[j] = a2 / d_[j];
    length_m_ += d_[j];
  }
  ++mesh_version_;
  factors_.clear();
}

std::vector<double> HeatColumn::node_positions_m() const {
  std::vector<double> z(t_.size(), 0.0);
  for (std::size_t j = 0; j < d_.size(); ++j) z[j + 1] = z[j] + d_[j];
  return z;
}

void HeatColumn::coarsen() {
  if (!coarsening_.enabled) return;
  bool changed = false;
  for (;;) {
    bool merged_one = false;
    double z = 0.0;  // z_j
    for (std::size_t j = 1; j + 1 < t_.size(); ++j) {
      z += d_[j - 1];
      const double dl = d_[j - 1], dr = d_[j];
      const double merged = dl + dr;
      const double depth = length_m_ - (z + dr);  // depth of the merged interval's top end
      if (!(dl == dr && depth >= coarsening_.min_depth_m &&
            merged <= coarsening_.grading * depth))
        continue;
      // Remove node j; its heat cap_j T_j goes dr/2 to node j-1 and dl/2 to node j+1.
      const double cl = cap_[j - 1], cr = cap_[j + 1];
      t_[j - 1] = (cl * t_[j - 1] + 0.5 * dr * t_[j]) / (cl + 0.5 * dr);
      t_[j + 1] = (cr * t_[j + 1] + 0.5 * dl * t_[j]) / (cr + 0.5 * dl);
      cap_[j - 1] = cl + 0.5 * dr;
      cap_[j + 1] = cr + 0.5 * dl;
      t_.erase(t_.begin() + std::ptrdiff_t(j));
      cap_.erase(cap_.begin() + std::ptrdiff_t(j));
      d_[j - 1] = merged;
      d_.erase(d_.begin() + std::ptrdiff_t(j));
      merged_one = changed = true;
      break;
    }
    if (!merged_one) break;
  }
  if (changed) rebuild_mesh();
}

void HeatColumn::set_temperatures(const std::vector<double>& temps_c) {
  if (temps_c.size() != t_.size())
    throw Error("set_temperatures needs " + std::to_string(t_.size()) + " values, got " +
                std::to_string(temps_c.size()));
  t_ = temps_c;
  have_prev_ = false;
  fresh_start_ = true;
}

double HeatColumn::heat_j_m2() const {
  double sum = 0.0;
  for (std::size_t j = 0; j < t_.size(); ++j) sum += cap_[j] * t_[j];
  return material_.volumetric_heat_j_m3k() * sum;
}

void HeatColumn::apply_k(const std::vector<double>& x, std::vector<double>& y) const {
  const std::size_t n = x.size();
  y.resize(n);
  y[0] = g_[0] * (x[0] - x[1]);
  for (std::size_t j = 1; j + 1 < n; ++j)
    y[j] = g_[j - 1] * (x[j] - x[j - 1]) + g_[j] * (x[j] - x[j + 1]);
  y[n - 1] = g_[n - 2] * (x[n - 1] - x[n - 2]);
}

void HeatColumn::solve(double alpha, double beta, std::vector<double>& rhs) {
  const std::size_t n = rhs.size();
  Factor* f = nullptr;
  for (auto& c : factors_)
    if (c.version == mesh_version_ && c.alpha == alpha && c.beta == beta) f = &c;
  if (!f) {
    if (factors_.size() >= 4) factors_.erase(factors_.begin());
    factors_.push_back({alpha, beta, mesh_version_, std::vector<double>(n), std::vector<double>(n)});
    f = &factors_.back();
    // Row j: -beta g_{j-1} x_{j-1} + (alpha c_j + beta (g_{j-1} + g_j)) x_j - beta g_j x_{j+1}
    double m = alpha * cap_[0] + beta * g_[0];
    f->inv_m[0] = 1.0 / m;
    f->cprime[0] = -beta * g_[0] / m;
    for (std::size_t j = 1; j < n; ++j) {
      const double gl = g_[j - 1], gr = (j + 1 < n) ? g_[j] : 0.0;
      m = alpha * cap_[j] + beta * (gl + gr) + beta * gl * f->cprime[j - 1];
      f->inv_m[j] = 1.0 / m;
      f->cprime[j] = -beta * gr / m;
    }
  }
  const double* cp = f->cprime.data();
  const double* im = f->inv_m.data();
  const double* g = g_.data();
  double* x = rhs.data();
  x[0] *= im[0];
  for (std::size_t j = 1; j < n; ++j) x[j] = (x[j] + beta * g[j - 1] * x[j - 1]) * im[j];
  for (std::size_t j = n - 1; j-- > 0;) x[j] -= cp[j] * x[j + 1];
}

void HeatColumn::implicit_step(double dt, double flux, double theta) {
  // C T' = -K T + e_top q, q = U/(rho Cp); theta-method with the flux held over the step.
  const double q = flux / material_.volumetric_heat_j_m3k();
  const std::size_t n = t_.size();
  apply_k(t_, work_);
  rhs_.resize(n);
  for (std::size_t j = 0; j < n; ++j) rhs_[j] = cap_[j] * t_[j] - (1.0 - theta) * dt * work_[j];
  rhs_[n - 1] += dt * q;
  solve(1.0, theta * dt, rhs_);
  t_prev_.swap(t_);
  t_.swap(rhs_);
  have_prev_ = true;
}

void HeatColumn::step(double dt, double flux) {
  require_positive("time step dt, s", dt);
  require_finite("top flux, W/m^2", flux);
  const std::size_t n = t_.size();
  const double q = flux / material_.volumetric_heat_j_m3k();
  switch (scheme_) {
    case TimeScheme::tr_bdf2: {
      const double g = 2.0 - std::sqrt(2.0);
      // Stage 1, trapezoid over g dt: (C + g dt/2 K) Tg = (C - g dt/2 K) T + g dt e q
      apply_k(t_, work_);
      rhs_.resize(n);
      const double c = 0.5 * g * dt;
      for (std::size_t j = 0; j < n; ++j) rhs_[j] = cap_[j] * t_[j] - c * work_[j];
      rhs_[n - 1] += g * dt * q;
      solve(1.0, c, rhs_);
      // Stage 2, BDF2 through T, Tg, T+:
      // (C + w dt K) T+ = C (Tg - (1-g)^2 T)/(g (2-g)) + w dt e q,  w = (1-g)/(2-g)
      const double w = (1.0 - g) / (2.0 - g);
      const double c1 = 1.0 / (g * (2.0 - g)), c0 = (1.0 - g) * (1.0 - g) / (g * (2.0 - g));
      for (std::size_t j = 0; j < n; ++j) rhs_[j] = cap_[j] * (c1 * rhs_[j] - c0 * t_[j]);
      rhs_[n - 1] += w * dt * q;
      solve(1.0, w * dt, rhs_);
      t_prev_.swap(t_);
      t_.swap(rhs_);
      have_prev_ = true;
      return;
    }
    case TimeScheme::backward_euler:
      implicit_step(dt, flux, 1.0);
      return;
    case TimeScheme::crank_nicolson:
      if (fresh_start_ && rannacher_half_steps_ > 0) {
        // Rannacher start-up: damp the stiff components excited by non-smooth data.
        for (int i = 0; i < rannacher_half_steps_; ++i)
          implicit_step(dt / rannacher_half_steps_, flux, 1.0);
      } else {
        implicit_step(dt, flux, 0.5);
      }
      fresh_start_ = false;
      return;
    case TimeScheme::bdf2: {
      if (!have_prev_) {
        implicit_step(dt, flux, 1.0);  // one BE step starts the two-step method
        return;
      }
      rhs_.resize(n);
      // (3 C + 2 dt K) T+ = C (4 T - T-) + 2 dt e q
      for (std::size_t j = 0; j < n; ++j) rhs_[j] = cap_[j] * (4.0 * t_[j] - t_prev_[j]);
      rhs_[n - 1] += 2.0 * dt * q;
      solve(3.0, 2.0 * dt, rhs_);
      t_prev_.swap(t_);
      t_.swap(rhs_);
      return;
    }
  }
}

void HeatColumn::add_layer(int cells, double temp_c) {
  if (cells < 1) throw Error("add_layer needs cells >= 1, got " + std::to_string(cells));
  require_finite("fresh powder temperature, C", temp_c);
  // The old top node's control volume grows by half a fresh cell: mix the heat.
  const double ctop = cap_.back();
  t_.back() = (ctop * t_.back() + 0.5 * cell_m_ * temp_c) / (ctop + 0.5 * cell_m_);
  t_.insert(t_.end(), std::size_t(cells), temp_c);
  d_.insert(d_.end(), std::size_t(cells), cell_m_);
  rebuild_mesh();
  coarsen();
  have_prev_ = false;
  fresh_start_ = true;
}

}  // namespace amctl::thermal
