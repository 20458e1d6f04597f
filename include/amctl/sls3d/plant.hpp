#pragma once
// The finite-element plant of the SLS powder bed in 3D (docs/sls3d.md): a transient heat
// equation with latent heat on a growing stack of powder layers, solved with deal.II on a
// distributed (p4est) mesh. This header holds only plain value types and an abstract
// interface: the deal.II code lives in a separately loaded engine (src/sls3d/fe/), so nothing
// else in amctl compiles against deal.II or loads it (loading libdeal.ii costs ~0.3 s and
// ~150 MB per process; docs/sls3d.md, "Build and loading").
//
// Units: SI throughout (m, s, W, J, K); temperatures in degrees Celsius where a name says _c.
//
// The plant solves, on the deposited part of the domain Omega(t),
//   dH(T; s)/dt = div(k(s) grad T)
//   k dT/dn = q_laser + U - eps sigma (T^4 - T_env^4) - h (T - T_gas)   on the top surface,
//   k dT/dn = 0 elsewhere (build platform and side walls insulated),
// with the enthalpy per volume H(T; s) = rho c(s) T + rho(s) L max(s, f(T)), f the melt
// fraction (a smooth step from solidus to liquidus) and s in [0, 1] the consolidation state
// of a cell (the largest melt fraction it has reached; powder s = 0, sintered s = 1).
// Time: the theta scheme (backward Euler or Crank-Nicolson) in enthalpy form, Newton on the
// nodal (mass-lumped) enthalpy; every step conserves energy to the nonlinear tolerance.
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace amctl::sls3d {

/// One state of the material (powder or sintered).
struct Material {
  double conductivity_w_mk = 0.28;
  double density_kg_m3 = 1010.0;
  double specific_heat_j_kgk = 1928.0;
  [[nodiscard]] double volumetric_heat_j_m3k() const { return density_kg_m3 * specific_heat_j_kgk; }
  [[nodiscard]] double diffusivity_m2_s() const {
    return conductivity_w_mk / volumetric_heat_j_m3k();
  }
};

/// Latent heat absorbed between solidus and liquidus (melt fraction 3 x^2 - 2 x^3 of
/// x = (T - solidus)/(liquidus - solidus)). Molten material does not recrystallise within the
/// run (the bed is held above the crystallisation onset: the SLS processing window).
struct Melting {
  bool enabled = false;
  double solidus_c = 176.0;
  double liquidus_c = 186.0;
  double latent_heat_j_kg = 1.0e5;
};

/// Heat lost by the top surface: grey-body radiation to surroundings at radiation_env_c and
/// convection to the chamber gas at gas_temp_c.
struct SurfaceLosses {
  double emissivity = 0.0;
  double radiation_env_c = 25.0;
  double convection_w_m2k = 0.0;
  double gas_temp_c = 25.0;
};

/// The mesh: a footprint (a disc centred at the origin or a rectangle) extruded over the
/// coarse z slices of the base (ending at z = 0, the base top) and `layers` layers of
/// `layer_thickness_m` above it, each made of `cells_per_layer` coarse slices. Only the base
/// is active at the start; add_layer() activates the next layer.
struct MeshSpec {
  enum class Footprint { disc, rectangle };
  Footprint footprint = Footprint::rectangle;
  double disc_radius_m = 0.1;
  double x0_m = 0.0, x1_m = 1e-3, y0_m = 0.0, y1_m = 1e-3;
  /// In-plane size of the coarse cells (the disc's coarse mesh is the nearest refinement of
  /// a 12-cell ball; a rectangle is subdivided to this size).
  double coarse_cell_m = 1e-3;
  /// z of the coarse slice boundaries of the base, ascending, the last one 0.
  std::vector<double> base_slices_m{-1e-3, 0.0};
  int layers = 0;
  double layer_thickness_m = 1e-4;
  int cells_per_layer = 1;
};

/// Linear and nonlinear solver settings.
struct SolverSettings {
  enum class Preconditioner { amg, jacobi, ssor };
  Preconditioner preconditioner = Preconditioner::amg;
  double linear_rel_tol = 1e-11;  ///< CG stops at |r| <= tol |b|
  int max_linear_iterations = 2000;
  double newton_rel_tol = 1e-8;   ///< Newton stops at |R| <= tol |R_0| (or see engine.cpp)
  int max_newton_iterations = 25;
};

struct PlantSpec {
  MeshSpec mesh;
  Material powder{};
  Material sintered{};
  Melting melting{};
  SurfaceLosses losses{};
  double initial_temp_c = 20.0;
  /// Consolidation state of the base at the start (0 powder, 1 sintered).
  double initial_state = 0.0;
  /// 1 = backward Euler, 0.5 = Crank-Nicolson.
  double theta = 1.0;
  SolverSettings solver{};
};

/// A straight piece of the laser path traversed at constant speed during [t0_s, t1_s]
/// (absolute times) with absorbed power power_w.
struct LaserPass {
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
  double t0_s = 0, t1_s = 0;
  double power_w = 0;
};

/// How the laser's heat enters a step.
enum class SourceModel {
  /// Resolved spot: q = 2P/(pi W^2) exp(-2 r^2/W^2) around the beam centre, averaged exactly
  /// over the part of the step it moves through (an erf strip along each pass).
  gaussian,
  /// Part scale: each pass deposits P/(v h) per unit area uniformly on its hatch strip (the
  /// pass widened to the hatch spacing h), within the step it is traversed in; the step's
  /// input is scaled so that it equals the pass energy exactly.
  lumped_strip,
};

/// What enters during one step [t_s, t_s + dt_s].
struct StepInput {
  double t_s = 0.0;
  double dt_s = 0.0;
  double top_flux_w_m2 = 0.0;  ///< U, uniform on the top surface, held over the step
  double theta = 0.0;          ///< this step's theta (0: the plant's)
  SourceModel source = SourceModel::gaussian;
  double beam_radius_m = 0.0;  ///< W (1/e^2 radius) of the gaussian model
  double hatch_m = 0.0;        ///< strip width of the lumped model
  std::vector<LaserPass> passes;
};

/// Energies of one step [J]; losses count positive when heat leaves.
struct StepReport {
  int newton_iterations = 0;
  int linear_iterations = 0;
  double residual_initial = 0.0;
  double residual_final = 0.0;
  double enthalpy_change_j = 0.0;
  double laser_j = 0.0;          ///< what the discrete source put in
  double laser_nominal_j = 0.0;  ///< sum of P (t1 - t0) over the passes
  double top_flux_j = 0.0;
  double radiation_j = 0.0;
  double convection_j = 0.0;
  double balance_error_j = 0.0;      ///< enthalpy change - (laser + flux - losses)
  double balance_rel_error = 0.0;    ///< |error| / max(|dH| + |laser| + |flux| + losses, 1e-12 |H|)
  int cells_consolidated = 0;        ///< cells whose state rose after the step
  double densification_j = 0.0;      ///< enthalpy change of that state update (see docs)
  double max_temp_c = 0.0;           ///< largest nodal temperature after the step
};

/// A place where the mesh is refined to `level` (refinements of the coarse cell): a capsule
/// (the set of points within radius_m of the segment (x0,y0)-(x1,y1) in the plane) or an
/// annulus around the origin (r0_m <= r <= r1_m), for cells whose top is at most depth_m
/// below the current top surface (cells above it count as at the top).
struct RefineZone {
  enum class Shape { capsule, annulus };
  Shape shape = Shape::capsule;
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0, radius_m = 0;
  double r0_m = 0, r1_m = 0;
  double depth_m = 1e9;
  int level = 0;
};

struct RemeshReport {
  int passes = 0;
  bool changed = false;
  double enthalpy_change_j = 0.0;  ///< interpolation onto the new mesh (refinement is exact)
};

struct LayerReport {
  int layer = 0;                     ///< layers active after the addition
  double top_z_m = 0.0;
  double enthalpy_change_j = 0.0;    ///< measured
  double fresh_enthalpy_j = 0.0;     ///< the new powder's enthalpy at its temperature
};

/// A weighted mean over the top surface: a Gaussian pyrometer spot exp(-2 r^2/R^2) around
/// (x, y) with 1/e^2 radius R, or the plain mean over r0 <= |p - (x, y)| <= r1.
struct TopWeight {
  enum class Kind { spot, area };
  Kind kind = Kind::area;
  double x_m = 0, y_m = 0;
  double radius_m = 0;       ///< spot
  double r0_m = 0, r1_m = 1e9;  ///< area
};

struct TopMaximum {
  double temp_c = 0.0;
  std::array<double, 3> where_m{};
  double cell_size_m = 0.0;  ///< in-plane size of a cell at that point
};

/// Temperatures on a regular grid of the top surface (row-major, y rows), NaN outside.
struct TopRaster {
  double x0_m = 0, y0_m = 0, dx_m = 0, dy_m = 0;
  int nx = 0, ny = 0;
  std::vector<double> temp_c;
  std::vector<float> state;  ///< consolidation state of the cell under each pixel
};

struct MeshStats {
  std::uint64_t cells = 0;         ///< active cells of the mesh (deposited or not)
  std::uint64_t active_cells = 0;  ///< cells of the deposited domain
  std::uint64_t dofs = 0;
  int max_level = 0;
  int ranks = 1;
  int rank = 0;
  int layers = 0;                  ///< layers deposited
};

/// The plant. Every call is collective under MPI: all ranks make the same calls in the same
/// order; results are the same on every rank.
class Plant {
 public:
  virtual ~Plant() = default;
  /// Advances one step. Throws amctl::Error ("step N at t = ... s: ...") when Newton or CG
  /// does not converge.
  virtual StepReport step(const StepInput& in) = 0;
  /// Activates the next layer: its new nodes at fresh_temp_c, the nodes it shares with the
  /// old top at the capacity-weighted mean (so the sensible heat added is exactly that of the
  /// fresh powder). Throws amctl::InternalError when no layer is left.
  virtual LayerReport add_layer(double fresh_temp_c) = 0;
  /// Refines to the zones' levels (the largest level whose zone touches a cell; 0 elsewhere)
  /// and coarsens elsewhere, one level per pass, the temperature and the cell states carried
  /// over.
  virtual RemeshReport remesh(const std::vector<RefineZone>& zones) = 0;
  [[nodiscard]] virtual double top_mean(const TopWeight& w) const = 0;
  /// T at points (NaN outside the deposited domain).
  [[nodiscard]] virtual std::vector<double> evaluate(
      const std::vector<std::array<double, 3>>& points_m) const = 0;
  [[nodiscard]] virtual TopMaximum top_maximum() const = 0;
  [[nodiscard]] virtual TopRaster raster_top(double x0_m, double y0_m, double dx_m, double dy_m,
                                             int nx, int ny) const = 0;
  /// The VTU snapshot (one file for all ranks) of the deposited domain: temperature,
  /// consolidation state, conductivity, owning rank. Collective; on rank 0 `sink` receives
  /// the file's bytes in order (header, each rank's piece, footer), one piece at a time, then
  /// an empty view that marks the end (where the host commits the file); it is never called
  /// on the others. The engine writes no file: the host writes the bytes with
  /// its own output writer. An exception from `sink` is rethrown on rank 0 after every rank's
  /// piece was taken (the other ranks throw amctl::Error), so no rank is left waiting.
  virtual void write_vtu(const std::function<void(std::string_view)>& sink, double time_s) = 0;
  [[nodiscard]] virtual MeshStats stats() const = 0;
  [[nodiscard]] virtual double top_z_m() const = 0;
  [[nodiscard]] virtual double enthalpy_j() const = 0;
  /// Top surface area of the deposited domain (quadrature of the mesh), m^2.
  [[nodiscard]] virtual double top_area_m2() const = 0;
  /// Sets every node to temp_c.
  virtual void set_uniform_temperature(double temp_c) = 0;
  /// Wall-clock seconds spent in the solver (assembly + linear solves) so far.
  [[nodiscard]] virtual double solve_seconds() const = 0;
  /// MPI barrier then true on rank 0 (for writing shared files).
  virtual void barrier() = 0;
};

/// Builds a plant (loads the finite-element engine on first use, initialising MPI if no one
/// has). Throws amctl::Error when the engine is not available (built without deal.II, or the
/// library not found: the message says where it looked).
[[nodiscard]] std::unique_ptr<Plant> make_plant(const PlantSpec& spec);

/// True when the engine can be loaded; otherwise `why` says why not.
[[nodiscard]] bool engine_available(std::string* why = nullptr);

/// The rank an MPI launcher (mpirun) gave this process, read from its environment
/// (OMPI_COMM_WORLD_RANK, PMIX_RANK, PMI_RANK) without initialising MPI; 0 without a launcher.
/// Only rank 0 prints and writes the shared files.
[[nodiscard]] int launcher_rank();

/// The engine's entry point (src/sls3d/fe/engine.cpp), looked up by name in the loaded library.
using MakePlantFn = void (*)(const PlantSpec& spec, std::unique_ptr<Plant>& out);
inline constexpr const char* kEngineEntryPoint = "amctl_sls3d_make_plant";

}  // namespace amctl::sls3d
