#include "amctl/thermal/powder_bed_sim.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "amctl/core/error.hpp"

namespace amctl::thermal {

const char* to_string(AntiWindup a) {
  switch (a) {
    case AntiWindup::none: return "none";
    case AntiWindup::back_calculation: return "back_calculation";
    case AntiWindup::conditional_integration: return "conditional_integration";
  }
  return "?";
}

const char* to_string(TimeScheme s) {
  switch (s) {
    case TimeScheme::crank_nicolson: return "crank_nicolson";
    case TimeScheme::bdf2: return "bdf2";
    case TimeScheme::backward_euler: return "backward_euler";
  }
  return "?";
}

HeatColumn::HeatColumn(const PowderMaterial& material, double cell_m, int cells,
                       double initial_temp_c, TimeScheme scheme, int rannacher_half_steps)
    : material_(material), cell_m_(cell_m), scheme_(scheme),
      rannacher_half_steps_(rannacher_half_steps) {
  material_.validate();
  require_positive("cell size (layer thickness / cells_per_layer), m", cell_m);
  if (cells < 1) throw Error("heat column needs at least one cell, got " + std::to_string(cells));
  require_finite("initial temperature, C", initial_temp_c);
  if (rannacher_half_steps < 0)
    throw Error("rannacher_half_steps must be >= 0, got " + std::to_string(rannacher_half_steps));
  t_.assign(std::size_t(cells) + 1, initial_temp_c);
}

void HeatColumn::set_temperatures(const std::vector<double>& temps_c) {
  if (temps_c.size() < 2) throw Error("set_temperatures needs at least two nodes");
  t_ = temps_c;
  have_prev_ = false;
  fresh_start_ = true;
}

double HeatColumn::heat_j_m2() const {
  const double c = material_.volumetric_heat_j_m3k() * cell_m_;
  double sum = 0.5 * (t_.front() + t_.back());
  for (std::size_t j = 1; j + 1 < t_.size(); ++j) sum += t_[j];
  return c * sum;
}

// Solves (diag_scale * Cn + off_scale * L) x = rhs in place, where Cn = diag(1/2, 1, ..., 1, 1/2)
// is the normalised capacity and L the normalised stiffness (end rows [1 -1], interior
// [-1 2 -1]); `off` is off_scale. Thomas algorithm, O(n).
void HeatColumn::solve_tridiagonal(double diag_scale, double off, std::vector<double>& rhs) {
  const std::size_t n = rhs.size();
  cprime_.resize(n);
  auto diag = [&](std::size_t j) {
    const bool end = (j == 0 || j + 1 == n);
    return end ? 0.5 * diag_scale + off : diag_scale + 2.0 * off;
  };
  double b = diag(0);
  cprime_[0] = -off / b;
  rhs[0] /= b;
  for (std::size_t j = 1; j < n; ++j) {
    const double m = diag(j) - (-off) * cprime_[j - 1];
    cprime_[j] = (j + 1 < n) ? -off / m : 0.0;
    rhs[j] = (rhs[j] - (-off) * rhs[j - 1]) / m;
  }
  for (std::size_t j = n - 1; j-- > 0;) rhs[j] -= cprime_[j] * rhs[j + 1];
}

namespace {
// y = L x for the normalised stiffness (Neumann ends).
inline double lap(const std::vector<double>& x, std::size_t j) {
  const std::size_t n = x.size();
  if (j == 0) return x[0] - x[1];
  if (j + 1 == n) return x[n - 1] - x[n - 2];
  return 2.0 * x[j] - x[j - 1] - x[j + 1];
}
}  // namespace

void HeatColumn::implicit_step(double dt, double flux, double theta) {
  // Normalised by rho Cp h: Cn T' = -lambda L T + e_top q, lambda = a^2/h^2, q = U/(rho Cp h).
  const double lambda = material_.diffusivity_m2_s() / (cell_m_ * cell_m_);
  const double q = flux / (material_.volumetric_heat_j_m3k() * cell_m_);
  const std::size_t n = t_.size();
  rhs_.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const double cj = (j == 0 || j + 1 == n) ? 0.5 : 1.0;
    rhs_[j] = cj * t_[j] - (1.0 - theta) * dt * lambda * lap(t_, j);
  }
  rhs_[n - 1] += dt * q;
  solve_tridiagonal(1.0, theta * dt * lambda, rhs_);
  t_prev_.swap(t_);
  t_.swap(rhs_);
  have_prev_ = true;
}

void HeatColumn::step(double dt, double flux) {
  require_positive("time step dt, s", dt);
  require_finite("top flux, W/m^2", flux);
  switch (scheme_) {
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
      const double lambda = material_.diffusivity_m2_s() / (cell_m_ * cell_m_);
      const double q = flux / (material_.volumetric_heat_j_m3k() * cell_m_);
      const std::size_t n = t_.size();
      rhs_.resize(n);
      // (3 Cn + 2 dt lambda L) T+ = Cn (4 T - T-) + 2 dt e_top q
      for (std::size_t j = 0; j < n; ++j) {
        const double cj = (j == 0 || j + 1 == n) ? 0.5 : 1.0;
        rhs_[j] = cj * (4.0 * t_[j] - t_prev_[j]);
      }
      rhs_[n - 1] += 2.0 * dt * q;
      solve_tridiagonal(3.0, 2.0 * dt * lambda, rhs_);
      t_prev_.swap(t_);
      t_.swap(rhs_);
      return;
    }
  }
}

void HeatColumn::add_layer(int cells, double temp_c) {
  if (cells < 1) throw Error("add_layer needs cells >= 1, got " + std::to_string(cells));
  require_finite("fresh powder temperature, C", temp_c);
  // The old top half cell is completed by half a cell of fresh powder: mix the energies.
  t_.back() = 0.5 * (t_.back() + temp_c);
  t_.insert(t_.end(), std::size_t(cells), temp_c);
  have_prev_ = false;
  fresh_start_ = true;
}

}  // namespace amctl::thermal
