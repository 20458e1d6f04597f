// The verification cases of the 3D plant (amctl/sls3d/studies.hpp): a slab under a uniform
// flux and under the PI, a moving Gaussian source on a semi-infinite body, and the lumping
// error of the part-scale source on a hatched patch.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "amctl/control/pid.hpp"
#include "amctl/core/error.hpp"
#include "amctl/numerics/scalar_search.hpp"
#include "amctl/sls3d/scan.hpp"
#include "amctl/sls3d/studies.hpp"

namespace amctl::sls3d {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string g(double v) { return fmt::format("{:g}", v); }

void check_material(const Material& m, const std::string& prefix) {
  if (!(m.conductivity_w_mk > 0) || !std::isfinite(m.conductivity_w_mk))
    throw Error(prefix + "conductivity-w-mk: must be > 0, got " + g(m.conductivity_w_mk));
  if (!(m.density_kg_m3 > 0) || !std::isfinite(m.density_kg_m3))
    throw Error(prefix + "density-kg-m3: must be > 0, got " + g(m.density_kg_m3));
  if (!(m.specific_heat_j_kgk > 0) || !std::isfinite(m.specific_heat_j_kgk))
    throw Error(prefix + "specific-heat-j-kgk: must be > 0, got " + g(m.specific_heat_j_kgk));
}

void check_times(const std::vector<double>& times) {
  if (times.empty()) throw Error("--times-s: found no time, expected one or more times > 0");
  double last = 0;
  for (double t : times) {
    if (!(t > last) || !std::isfinite(t))
      throw Error("--times-s: found " + g(t) + ", expected increasing times > 0 s");
    last = t;
  }
}

double seconds_of(Scheme s) { return s == Scheme::crank_nicolson ? 0.5 : 1.0; }

// A column of `cells` cubes through a slab of thickness L (the top at z = 0): the uniform
// flux makes the problem one-dimensional, so one column of cells is the whole slab.
PlantSpec slab_spec(double thickness_m, int cells, const Material& m, Scheme scheme) {
  PlantSpec p;
  const double h = thickness_m / cells;
  p.mesh.footprint = MeshSpec::Footprint::rectangle;
  p.mesh.x0_m = 0;
  p.mesh.x1_m = h;
  p.mesh.y0_m = 0;
  p.mesh.y1_m = h;
  p.mesh.coarse_cell_m = h;
  p.mesh.base_slices_m.clear();
  for (int i = 0; i <= cells; ++i) p.mesh.base_slices_m.push_back(-thickness_m + i * h);
  p.mesh.base_slices_m.back() = 0.0;
  p.mesh.layers = 0;
  p.powder = m;
  p.sintered = m;
  p.initial_temp_c = 0.0;
  p.theta = seconds_of(scheme);
  p.solver.preconditioner = SolverSettings::Preconditioner::jacobi;
  return p;
}

// Step sizes that land on every requested time: at most max_dt and at most 1/20 of each
// interval.
std::vector<double> step_sizes(const std::vector<double>& times, double max_dt) {
  std::vector<double> dts;
  double t = 0;
  for (double tk : times) {
    const double span = tk - t;
    const int n = std::max(20, int(std::ceil(span / max_dt - 1e-9)));
    for (int i = 0; i < n; ++i) dts.push_back(span / n);
    t = tk;
  }
  return dts;
}

}  // namespace

const char* to_string(Scheme s) {
  return s == Scheme::crank_nicolson ? "crank_nicolson" : "backward_euler";
}

// ----------------------------------------------------------------------------------------
// Slab under a uniform flux.

void SlabFluxOptions::validate() const {
  if (!(thickness_m > 0) || !std::isfinite(thickness_m))
    throw Error("--thickness-mm: must be > 0, got " + g(thickness_m * 1e3));
  if (!std::isfinite(flux_w_m2)) throw Error("--flux-w-m2: found " + g(flux_w_m2) + ", expected a finite flux");
  check_times(times_s);
  check_material(material, "--");
  if (cells < 2 || cells > 4096) throw Error("--cells: must be in [2, 4096], got " + std::to_string(cells));
  if (!(max_dt_s >= 0) || !std::isfinite(max_dt_s))
    throw Error("--dt-s: must be >= 0 (0: automatic), got " + g(max_dt_s));
}

double slab_flux_top_rise(const Material& m, double thickness_m, double flux_w_m2, double t_s) {
  // T(L, t) = q t/(rho c L) + (q L/k) [1/3 - (2/pi^2) sum_n exp(-n^2 pi^2 a t/L^2)/n^2]
  const double a = m.diffusivity_m2_s(), l = thickness_m, q = flux_w_m2;
  const double pi2 = std::numbers::pi * std::numbers::pi;
  double sum = 0;
  for (int n = 1; n < 100000; ++n) {
    const double term = std::exp(-n * n * pi2 * a * t_s / (l * l)) / (double(n) * n);
    sum += term;
    if (term < 1e-17 * std::max(sum, 1e-300)) break;
  }
  return q * t_s / (m.volumetric_heat_j_m3k() * l) + q * l / m.conductivity_w_mk * (1.0 / 3.0 - 2.0 / pi2 * sum);
}

SlabFluxResult run_slab_flux(const SlabFluxOptions& o) {
  o.validate();
  const auto t0 = Clock::now();
  SlabFluxResult r;
  r.options = o;
  const double tau = o.thickness_m * o.thickness_m / o.material.diffusivity_m2_s();
  const double max_dt = o.max_dt_s > 0 ? o.max_dt_s : tau / 100.0;
  auto plant = make_plant(slab_spec(o.thickness_m, o.cells, o.material, o.scheme));
  const TopWeight everywhere{TopWeight::Kind::area, 0, 0, 0, 0, 1e9};
  double t = 0;
  std::size_t next = 0;
  const std::vector<double> dts = step_sizes(o.times_s, max_dt);
  for (std::size_t k = 0; k < dts.size(); ++k) {
    StepInput in;
    in.top_flux_w_m2 = o.flux_w_m2;
    // Crank-Nicolson starts with two backward-Euler half steps (Rannacher 1984): the flux
    // switched on at t = 0 would leave undamped oscillations of the stiff modes.
    const int sub = (k == 0 && o.scheme == Scheme::crank_nicolson) ? 2 : 1;
    for (int s = 0; s < sub; ++s) {
      in.t_s = t;
      in.dt_s = dts[k] / sub;
      in.theta = sub == 2 ? 1.0 : 0.0;
      const StepReport sr = plant->step(in);
      r.energy_balance_rel_error = std::max(r.energy_balance_rel_error, sr.balance_rel_error);
      t += in.dt_s;
      ++r.steps;
    }
    if (next < o.times_s.size() && std::abs(t - o.times_s[next]) <= 1e-9 * o.times_s[next]) {
      r.top_rise_k.push_back(plant->top_mean(everywhere));
      r.series_top_rise_k.push_back(slab_flux_top_rise(o.material, o.thickness_m, o.flux_w_m2, o.times_s[next]));
      t = o.times_s[next];
      ++next;
    }
  }
  const MeshStats ms = plant->stats();
  r.cells = ms.active_cells;
  r.dofs = ms.dofs;
  r.wall_s = seconds_since(t0);
  return r;
}

// ----------------------------------------------------------------------------------------
// Slab under the PI.

void SlabPiOptions::validate() const {
  if (!(thickness_m > 0) || !std::isfinite(thickness_m))
    throw Error("--thickness-mm: must be > 0, got " + g(thickness_m * 1e3));
  if (!std::isfinite(setpoint_rise_k))
    throw Error("--setpoint-rise-k: found " + g(setpoint_rise_k) + ", expected a finite number");
  if (!(kp_w_m2k >= 0) || !std::isfinite(kp_w_m2k))
    throw Error("--kp: must be >= 0 W/(m^2 K), got " + g(kp_w_m2k));
  if (!(ti_s > 0) || !std::isfinite(ti_s)) throw Error("--ti-s: must be > 0 s, got " + g(ti_s));
  check_times(times_s);
  check_material(material, "--");
  if (cells < 2 || cells > 4096) throw Error("--cells: must be in [2, 4096], got " + std::to_string(cells));
  if (!(max_dt_s >= 0) || !std::isfinite(max_dt_s))
    throw Error("--dt-s: must be >= 0 (0: automatic), got " + g(max_dt_s));
}

SlabPiResult run_slab_pi(const SlabPiOptions& o) {
  o.validate();
  const auto t0 = Clock::now();
  SlabPiResult r;
  r.options = o;
  const double tau = o.thickness_m * o.thickness_m / o.material.diffusivity_m2_s();
  const double dt =
      o.max_dt_s > 0 ? o.max_dt_s : std::min({0.01, o.ti_s / 50.0, std::max(tau / 4.0, 1e-4)});
  auto plant = make_plant(slab_spec(o.thickness_m, o.cells, o.material, o.scheme));
  const TopWeight everywhere{TopWeight::Kind::area, 0, 0, 0, 0, 1e9};
  // The 1D design's PI, unsaturated: C(s) = kp (Ti s + 1)/(Ti s) on e = S - y, sampled every
  // step, its output held over the step.
  control::PidController pi(control::PidGains::standard(o.kp_w_m2k, o.ti_s), control::PidOptions{});
  double t = 0;
  bool first = true;
  for (double tk : o.times_s) {
    const int n = std::max(1, int(std::ceil((tk - t) / dt - 1e-9)));
    const double h = (tk - t) / n;
    for (int i = 0; i < n; ++i) {
      const double y = plant->top_mean(everywhere);
      const double u = pi.update(o.setpoint_rise_k, y, h);
      StepInput in;
      in.top_flux_w_m2 = u;
      const int sub = (first && o.scheme == Scheme::crank_nicolson) ? 2 : 1;
      for (int s = 0; s < sub; ++s) {
        in.t_s = t;
        in.dt_s = h / sub;
        in.theta = sub == 2 ? 1.0 : 0.0;
        const StepReport sr = plant->step(in);
        r.energy_balance_rel_error = std::max(r.energy_balance_rel_error, sr.balance_rel_error);
        t += in.dt_s;
        ++r.steps;
      }
      first = false;
    }
    t = tk;
    const double y = plant->top_mean(everywhere);
    r.top_rise_k.push_back(y);
    r.flux_w_m2.push_back(control::PidController(pi).update(o.setpoint_rise_k, y, h));
  }
  const MeshStats ms = plant->stats();
  r.cells = ms.active_cells;
  r.dofs = ms.dofs;
  r.wall_s = seconds_since(t0);
  return r;
}

// ----------------------------------------------------------------------------------------
// Eagar-Tsai: the quasi-steady field of a Gaussian surface source of standard deviation
// sigma = W/2 moving at v over a half-space, from the instantaneous Gaussian surface source
//   dT = dQ/(rho c) [2 exp(-z^2/(4 a t))/sqrt(4 pi a t)] [exp(-(x^2+y^2)/(2 s^2 + 4 a t))/(2 pi (s^2 + 2 a t))]
// integrated over the release times t (substituted t = u^2 to remove the 1/sqrt(t)).

namespace {

// Adaptive Gauss-Kronrod (7, 15) on [a, b].
double gauss_kronrod(const std::function<double(double)>& f, double a, double b, double tol, int depth) {
  static const double xk[8] = {0.991455371120812639, 0.949107912342758525, 0.864864423359769073,
                               0.741531185599394440, 0.586087235467691130, 0.405845151377397167,
                               0.207784955007898468, 0.0};
  static const double wk[8] = {0.022935322010529225, 0.063092092629978553, 0.104790010322250184,
                               0.140653259715525919, 0.169004726639267903, 0.190350578064785410,
                               0.204432940075298892, 0.209482141084727828};
  static const double wg[4] = {0.129484966168869693, 0.279705391489276668, 0.381830050505118945,
                               0.417959183673469388};
  const double c = 0.5 * (a + b), h = 0.5 * (b - a);
  double k = wk[7] * f(c), gsum = wg[3] * f(c);
  for (int i = 0; i < 7; ++i) {
    const double f1 = f(c - h * xk[i]), f2 = f(c + h * xk[i]);
    k += wk[i] * (f1 + f2);
    if (i % 2 == 1) gsum += wg[i / 2] * (f1 + f2);
  }
  k *= h;
  gsum *= h;
  if (depth > 30 || std::abs(k - gsum) <= tol) return k;
  return gauss_kronrod(f, a, c, 0.5 * tol, depth + 1) + gauss_kronrod(f, c, b, 0.5 * tol, depth + 1);
}

}  // namespace

double eagar_tsai_rise(const Material& m, double power_w, double beam_radius_m, double speed_m_s,
                       double xi_m, double y_m, double z_m) {
  const double a = m.diffusivity_m2_s(), s2 = 0.25 * beam_radius_m * beam_radius_m, v = speed_m_s;
  const double pre = power_w / m.volumetric_heat_j_m3k() * 4.0 / std::sqrt(4.0 * std::numbers::pi * a);
  auto f = [&](double u) {
    const double t = u * u;
    const double depth = (t > 0) ? std::exp(-z_m * z_m / (4.0 * a * t)) : (z_m == 0 ? 1.0 : 0.0);
    const double x = xi_m + v * t;
    return depth / (2.0 * std::numbers::pi * (s2 + 2.0 * a * t)) *
           std::exp(-(x * x + y_m * y_m) / (2.0 * s2 + 4.0 * a * t));
  };
  // The integrand dies out once v^2 u^2/(4 a) and |x|/sqrt(a t) are large: integrate over
  // geometric pieces of u until a piece adds nothing. A first pass with a plain 15-point rule
  // gives the magnitude that sets the adaptive pass's absolute tolerance.
  const double u_scale = std::sqrt(s2 / a) + std::sqrt(std::abs(xi_m) / v) + std::sqrt(4.0 * a) / v;
  std::vector<std::pair<double, double>> pieces;
  double magnitude = 0;
  {
    double lo = 0, hi = 1e-4 * u_scale;
    for (int i = 0; i < 400; ++i) {
      pieces.push_back({lo, hi});
      const double part = gauss_kronrod(f, lo, hi, std::numeric_limits<double>::infinity(), 0);
      magnitude += std::abs(part);
      if (hi > 8.0 * u_scale && std::abs(part) < 1e-17 * magnitude) break;
      lo = hi;
      hi *= 1.25;
    }
  }
  if (magnitude == 0) return 0.0;
  const double tol = 1e-13 * magnitude / double(pieces.size());
  double total = 0;
  for (const auto& [lo, hi] : pieces) total += gauss_kronrod(f, lo, hi, tol, 0);
  return pre * total;
}

std::pair<double, double> eagar_tsai_peak(const Material& m, double power_w, double beam_radius_m,
                                          double speed_m_s) {
  // The surface temperature along the track is unimodal: golden section for its maximum.
  const double w = beam_radius_m, l = m.diffusivity_m2_s() / speed_m_s;
  double a = -(3.0 * w + 10.0 * l), b = w;
  auto f = [&](double x) { return -eagar_tsai_rise(m, power_w, w, speed_m_s, x, 0, 0); };
  numerics::GoldenSectionStop stop;
  stop.width = 1e-7 * w;
  const double x = numerics::golden_section_minimize(f, a, b, stop).midpoint();
  return {-f(x), x};
}

// ----------------------------------------------------------------------------------------
// Moving Gaussian source on a semi-infinite body.

void MovingSourceOptions::validate() const {
  if (!(power_w > 0) || !std::isfinite(power_w)) throw Error("--power-w: must be > 0, got " + g(power_w));
  if (!(beam_radius_m > 0) || !std::isfinite(beam_radius_m))
    throw Error("--beam-radius-mm: must be > 0, got " + g(beam_radius_m * 1e3));
  if (!(speed_m_s > 0) || !std::isfinite(speed_m_s))
    throw Error("--speed-mm-s: must be > 0 (a moving source), got " + g(speed_m_s * 1e3));
  check_material(material, "--");
  const double pe = speed_m_s * beam_radius_m / (2.0 * material.diffusivity_m2_s());
  if (pe < 0.05 || pe > 500)
    throw Error("--speed-mm-s: the Peclet number v W/(2 a) = " + g(pe) +
                " is outside [0.05, 500], the range the semi-infinite domain is sized for");
  for (const auto& p : probes_m)
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !(p[2] >= 0) || !std::isfinite(p[2]))
      throw Error("--probe-mm: found (" + g(p[0] * 1e3) + "," + g(p[1] * 1e3) + "," + g(p[2] * 1e3) +
                  "), expected finite X,Y,Z with the depth Z >= 0");
  if (cells_per_radius < 2 || cells_per_radius > 32)
    throw Error("--cells-per-radius: must be in [2, 32], got " + std::to_string(cells_per_radius));
  if (steps_per_radius < 1 || steps_per_radius > 256)
    throw Error("--steps-per-radius: must be in [1, 256], got " + std::to_string(steps_per_radius));
}

MovingSourceResult run_moving_source(const MovingSourceOptions& o) {
  o.validate();
  const auto t0 = Clock::now();
  MovingSourceResult r;
  r.options = o;
  const double w = o.beam_radius_m, v = o.speed_m_s, a = o.material.diffusivity_m2_s();
  const double l = a / v;  // thermal length ahead of the beam
  r.peclet = v * w / (2.0 * a);
  // Extents (docs/sls3d.md, section 4.3): the field decays like exp(-x/l) ahead of the beam and
  // like exp(-r/(2 l))/r across it; the travel brings the transient from the start below 1e-3.
  // The travel is a whole number of radii, so the beam ends at the same place relative to the
  // mesh whatever the steps per radius (a time-step study compares like with like).
  const double ahead = 4.0 * w + 8.0 * l, side = 4.0 * w + 14.0 * l;
  const double travel = std::ceil((8.0 * w + 24.0 * l) / w - 1e-9) * w;
  r.travel_m = travel;
  // Coarse cells twice as wide as tall, a few across the domain; octree levels down to
  // h_fine = W / cells_per_radius in the plane (h_fine / 2 vertically) around the beam.
  const double h_fine = w / o.cells_per_radius;
  const int levels = std::clamp(int(std::ceil(std::log2(side / 2.0 / h_fine))), 1, 7);
  const double h0 = h_fine * std::pow(2.0, levels);
  PlantSpec p;
  p.mesh.footprint = MeshSpec::Footprint::rectangle;
  p.mesh.x0_m = -side;
  p.mesh.x1_m = travel + ahead;
  p.mesh.y0_m = 0.0;
  p.mesh.y1_m = side;
  p.mesh.coarse_cell_m = h0;
  // Vertically the field near the beam varies over the penetration depth sqrt(a W / v) =
  // W / sqrt(2 Pe): the coarse slices near the top are `aspect` times thinner than wide so
  // that at 8 cells per radius the finest cells are about a quarter of it, growing to cubes
  // below. The aspect and the depth of the refined layers are fixed by the Peclet number
  // alone, so that other cells per radius refine (or coarsen) the same mesh in every
  // direction: a mesh study halves h in the plane and in depth alike.
  const double penetration = std::sqrt(a * w / v);
  const double h_ref = w / 8.0;
  const int aspect = std::clamp(1 << int(std::ceil(std::log2(std::max(1.0, 4.0 * h_ref / penetration)))), 2, 8);
  p.mesh.base_slices_m = {0.0};
  double dz = h0 / aspect;
  while (p.mesh.base_slices_m.back() > -side) {
    p.mesh.base_slices_m.push_back(p.mesh.base_slices_m.back() - dz);
    if (p.mesh.base_slices_m.size() > 2) dz = std::min(h0, 2.0 * dz);
  }
  std::reverse(p.mesh.base_slices_m.begin(), p.mesh.base_slices_m.end());
  const double h_z_ref = h_ref / aspect;  // the finest vertical size at 8 cells per radius
  p.powder = o.material;
  p.sintered = o.material;
  p.initial_temp_c = 0.0;
  p.theta = 0.5;
  p.solver.preconditioner = SolverSettings::Preconditioner::amg;
  auto plant = make_plant(p);
  const double dt = w / (o.steps_per_radius * v);
  const int steps = int(std::ceil(travel / (v * dt)));
  // Refinement: level `levels` within 2 W of the beam (and ahead of it for the steps until
  // the next remesh) and 4 cells deep; each coarser level twice as wide and deep, and
  // reaching further back along the wake.
  const int remesh_every = o.steps_per_radius;
  auto zones_at = [&](double xb) {
    std::vector<RefineZone> zones;
    for (int k = 0; k < levels; ++k) {
      const double grow = std::pow(2.0, k);
      RefineZone zn;
      zn.radius_m = 2.0 * w * grow;
      zn.x0_m = xb - 3.0 * l * grow;
      zn.x1_m = xb + (remesh_every + 1) * v * dt;
      zn.y0_m = zn.y1_m = 0.0;
      zn.depth_m = 4.0 * h_z_ref * grow + (k + 1 == levels ? side : 0.0);
      zn.level = levels - k;
      zones.push_back(zn);
    }
    return zones;
  };
  double t = 0, peak_one_radius_ago = 0;
  std::vector<double> peaks;
  for (int n = 0; n < steps; ++n) {
    if (n % remesh_every == 0) plant->remesh(zones_at(v * t));
    StepInput in;
    in.t_s = t;
    in.dt_s = dt;
    in.source = SourceModel::gaussian;
    in.beam_radius_m = w;
    // The full beam's power: the half y >= 0 receives exactly its half.
    in.passes.push_back(LaserPass{v * t, 0.0, v * (t + dt), 0.0, t, t + dt, o.power_w});
    const StepReport sr = plant->step(in);
    r.energy_balance_rel_error = std::max(r.energy_balance_rel_error, sr.balance_rel_error);
    t += dt;
    peaks.push_back(sr.max_temp_c);
    ++r.steps;
  }
  if (int(peaks.size()) > o.steps_per_radius) peak_one_radius_ago = peaks[peaks.size() - 1 - o.steps_per_radius];
  r.quasi_steady_drift = std::abs(peaks.back() - peak_one_radius_ago) / peaks.back();
  const double xb = v * t;
  // The peak: the largest node on the surface, then the parabola through it and its
  // neighbours along the track.
  const TopMaximum m = plant->top_maximum();
  const double h = m.cell_size_m, zs = -1e-9 * w;
  const std::vector<double> around =
      plant->evaluate({{m.where_m[0] - h, 0.0, zs}, {m.where_m[0], 0.0, zs}, {m.where_m[0] + h, 0.0, zs}});
  const double curv = around[0] - 2.0 * around[1] + around[2];
  double xpk = m.where_m[0], tpk = m.temp_c;
  if (curv < 0 && std::isfinite(curv)) {
    const double shift = 0.5 * h * (around[0] - around[2]) / curv;
    if (std::abs(shift) <= h) {
      xpk += shift;
      tpk = around[1] - (around[0] - around[2]) * (around[0] - around[2]) / (8.0 * curv);
    }
  }
  r.peak_rise_k = tpk;
  r.peak_x_m = xpk - xb;
  const auto [apk, ax] = eagar_tsai_peak(o.material, o.power_w, w, v);
  r.analytic_peak_rise_k = apk;
  r.analytic_peak_x_m = ax;
  std::vector<std::array<double, 3>> pts;
  for (const auto& pr : o.probes_m) pts.push_back({xb + pr[0], std::abs(pr[1]), std::min(-pr[2], zs)});
  const std::vector<double> vals = plant->evaluate(pts);
  for (std::size_t i = 0; i < pts.size(); ++i)
    r.probes.push_back({o.probes_m[i], vals[i],
                        eagar_tsai_rise(o.material, o.power_w, w, v, o.probes_m[i][0], o.probes_m[i][1],
                                        o.probes_m[i][2])});
  const MeshStats ms = plant->stats();
  r.cells = ms.active_cells;
  r.dofs = ms.dofs;
  r.wall_s = seconds_since(t0);
  return r;
}

// ----------------------------------------------------------------------------------------
// Lumping error of the part-scale source on a patch.

void LumpingPatchOptions::validate() const {
  if (!(patch_m > 0) || !std::isfinite(patch_m)) throw Error("--patch-mm: must be > 0, got " + g(patch_m * 1e3));
  if (!(power_w > 0) || !std::isfinite(power_w)) throw Error("--power-w: must be > 0, got " + g(power_w));
  if (!(beam_radius_m > 0) || !std::isfinite(beam_radius_m))
    throw Error("--beam-radius-mm: must be > 0, got " + g(beam_radius_m * 1e3));
  if (!(speed_m_s > 0) || !std::isfinite(speed_m_s))
    throw Error("--speed-mm-s: must be > 0, got " + g(speed_m_s * 1e3));
  if (!(hatch_m > 0) || !(hatch_m < patch_m))
    throw Error("--hatch-mm: must be in (0, patch), got " + g(hatch_m * 1e3));
  check_material(material, "--");
  if (!(part_scale_dt_s > 0)) throw Error("--dt-s: must be > 0, got " + g(part_scale_dt_s));
  double last = 0;
  for (double t : times_after_s)
    if (!(t > last)) throw Error("--times-s: found " + g(t) + ", expected increasing times > 0 s");
    else last = t;
}

LumpingPatchResult run_lumping_patch(const LumpingPatchOptions& o) {
  o.validate();
  const auto t0 = Clock::now();
  LumpingPatchResult r;
  r.options = o;
  const double half = 0.5 * o.patch_m, w = o.beam_radius_m;
  const double margin = std::max(1e-3, 4.0 * w);
  const ScanPath path = hatch_rectangle(-half, -half, half, half, HatchSettings{o.hatch_m, o.speed_m_s, 0.0});
  r.scan_time_s = path.duration_s();
  // The comparison instants: each requested time after the scan, rounded up to the
  // part-scale step grid (both runs are compared where the part scale has a solution).
  // Requested times that round to the same step give one row, not a repeated one.
  std::vector<double> times;
  for (double ta : o.times_after_s) {
    const double t = std::ceil((r.scan_time_s + ta) / o.part_scale_dt_s - 1e-9) * o.part_scale_dt_s;
    if (times.empty() || t > times.back() + 1e-9 * o.part_scale_dt_s) times.push_back(t);
  }
  const double h_fine = w / 4.0;
  const double extent = half + margin;
  const int levels = std::clamp(int(std::ceil(std::log2(extent / 2.0 / h_fine))), 1, 6);
  const double h0 = h_fine * std::pow(2.0, levels);
  PlantSpec p;
  p.mesh.footprint = MeshSpec::Footprint::rectangle;
  p.mesh.x0_m = p.mesh.y0_m = -extent;
  p.mesh.x1_m = p.mesh.y1_m = extent;
  p.mesh.coarse_cell_m = h0;
  std::vector<double> z{0.0};
  double dz = h0 / 8.0;
  while (z.back() > -extent) {
    z.push_back(z.back() - dz);
    dz = std::min(h0, dz * 1.5);
  }
  std::reverse(z.begin(), z.end());
  p.mesh.base_slices_m = z;
  p.powder = p.sintered = o.material;
  p.initial_temp_c = o.initial_temp_c;
  p.theta = 1.0;
  const std::vector<RefineZone> zones{
      RefineZone{RefineZone::Shape::capsule, -half, 0.0, half, 0.0, half + 2.0 * w, 0, 0, 3.0 * w, levels}};
  const int nx = 64;
  const double dxr = 2.0 * half / (nx - 1);
  struct Sample {
    std::vector<double> map;
    double mean = 0, max = 0;
  };
  auto sample = [&](Plant& pl) {
    Sample s;
    const TopRaster ras = pl.raster_top(-half, -half, dxr, dxr, nx, nx);
    s.map = ras.temp_c;
    double sum = 0;
    for (double v : s.map) sum += v;
    s.mean = sum / double(s.map.size());
    s.max = pl.top_maximum().temp_c;
    return s;
  };
  auto run = [&](bool fine, std::vector<Sample>& out, int& nsteps) {
    auto plant = make_plant(p);
    plant->remesh(zones);
    double t = 0;
    std::size_t k = 0;
    while (k < times.size()) {
      double dt;
      if (fine && t < r.scan_time_s - 1e-12) dt = std::min(w / (4.0 * o.speed_m_s), r.scan_time_s - t);
      else if (fine) dt = std::min({times[k] - t, std::max(1e-4, 0.25 * (t - r.scan_time_s + 1e-4))});
      else dt = std::min(o.part_scale_dt_s, times[k] - t);
      StepInput in;
      in.t_s = t;
      in.dt_s = dt;
      in.source = fine ? SourceModel::gaussian : SourceModel::lumped_strip;
      in.beam_radius_m = w;
      in.hatch_m = o.hatch_m;
      in.passes = path.passes(t, t + dt, 0.0, o.power_w);
      const StepReport sr = plant->step(in);
      r.energy_balance_rel_error = std::max(r.energy_balance_rel_error, sr.balance_rel_error);
      if (fine) r.fine_peak_c = std::max(r.fine_peak_c, sr.max_temp_c);
      t += dt;
      ++nsteps;
      if (std::abs(t - times[k]) <= 1e-9) {
        t = times[k];
        out.push_back(sample(*plant));
        ++k;
      }
    }
    const MeshStats ms = plant->stats();
    r.cells = ms.active_cells;
    r.dofs = ms.dofs;
  };
  std::vector<Sample> fine, lumped;
  run(true, fine, r.fine_steps);
  run(false, lumped, r.lumped_steps);
  for (std::size_t k = 0; k < times.size(); ++k) {
    LumpingPatchResult::Row row;
    row.t_s = times[k];
    row.after_scan_s = times[k] - r.scan_time_s;
    row.fine_mean_c = fine[k].mean;
    row.lumped_mean_c = lumped[k].mean;
    row.fine_max_c = fine[k].max;
    row.lumped_max_c = lumped[k].max;
    double s2 = 0;
    for (std::size_t i = 0; i < fine[k].map.size(); ++i) {
      const double d = fine[k].map[i] - lumped[k].map[i];
      s2 += d * d;
      row.max_difference_k = std::max(row.max_difference_k, std::abs(d));
    }
    row.rms_difference_k = std::sqrt(s2 / double(fine[k].map.size()));
    r.rows.push_back(row);
  }
  r.wall_s = seconds_since(t0);
  return r;
}

}  // namespace amctl::sls3d
