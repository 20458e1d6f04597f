#pragma once
// The finite-element plant of the SLS powder bed (docs/sls3d.md): deal.II 9.4 on a
// parallel::distributed::Triangulation (p4est), Q1 elements, the not-yet-spread layers as
// FE_Nothing cells (hp), Trilinos matrices and AMG. The engine's files (this header and
// src/sls3d/fe/*.cpp) are the only code of amctl that includes deal.II; they are built into a
// shared library loaded on first use (src/sls3d/engine_loader.cpp), so the rest of amctl
// neither compiles nor loads deal.II. An internal header: nothing outside src/sls3d/fe/
// includes it.
//
//   engine.cpp    the mesh, the growing domain (add_layer), refinement (remesh), MPI start-up
//                 and the library's entry point
//   assembly.cpp  the lumped enthalpy, the conductivity matrix, the Jacobian, the laser and
//                 the preheating flux, the consolidation states
//   solver.cpp    the time step: Newton (inexact, energy-conserving, through the enthalpy)
//                 and the linear solver (CG with AMG)
//   output.cpp    point location, top-surface means, maxima and maps, the VTU snapshot
//
// Discretisation (derived in docs/sls3d.md, section 2):
//   nodal (Gauss-Lobatto, mass-lumped) enthalpy  m_i H(T_i; s),
//   stiffness K_ij = int k(s) grad phi_i . grad phi_j  (Gauss 2x2x2),
//   top-surface losses lumped at the face nodes, laser and preheating flux with Gauss rules,
//   theta scheme R(T) = M[H(T) - H(T^n)] + theta dt (K T + L(T)) + (1 - theta) dt (K T^n + L(T^n))
//                      - dt (S + U) = 0,
// Newton on R with CG. Summing the residual over all nodes (the test function 1) gives
//   H(T^{n+1}) - H(T^n) + dt [theta L^{n+1} + (1 - theta) L^n] - dt (S + U) = sum_i R_i,
// so the energy balance of every step is exact up to the nonlinear tolerance.
#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/point.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/mapping_q1.h>
#include <deal.II/grid/grid_tools_cache.h>
#include <deal.II/hp/fe_collection.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d::fe {

using namespace dealii;
inline constexpr int dim = 3;
using Vec = TrilinosWrappers::MPI::Vector;
using Cell = DoFHandler<dim>::active_cell_iterator;
inline constexpr double kKelvin = 273.15;
inline constexpr double kStefanBoltzmann = 5.670374419e-8;
inline constexpr unsigned kActive = 0, kInactive = 1;

inline void sum_in_place(std::vector<double>& v, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), int(v.size()), MPI_DOUBLE, MPI_SUM, comm);
}

inline double smoothstep(double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  return x * x * (3.0 - 2.0 * x);
}
inline double smoothstep_slope(double x) { return (x <= 0 || x >= 1) ? 0.0 : 6.0 * x * (1.0 - x); }

// Material law of one cell (state s fixed within a step).
struct Law {
  double k, rho_c, rho_l;  // conductivity, volumetric heat, latent heat per volume
  double s, solidus, width;
  bool melting;
  [[nodiscard]] double fraction(double t) const {
    return melting ? smoothstep((t - solidus) / width) : 0.0;
  }
  [[nodiscard]] double enthalpy(double t) const {
    double h = rho_c * t;
    if (melting) h += rho_l * std::max(s, fraction(t));
    return h;
  }
  [[nodiscard]] double capacity(double t) const {
    double c = rho_c;
    if (melting && fraction(t) > s) c += rho_l * smoothstep_slope((t - solidus) / width) / width;
    return c;
  }
};

class FePlant final : public Plant {
 public:
  explicit FePlant(const PlantSpec& spec);

  StepReport step(const StepInput& in) override;
  LayerReport add_layer(double fresh_temp_c) override;
  RemeshReport remesh(const std::vector<RefineZone>& zones) override;
  [[nodiscard]] double top_mean(const TopWeight& w) const override;
  [[nodiscard]] std::vector<double> evaluate(
      const std::vector<std::array<double, 3>>& points_m) const override;
  [[nodiscard]] TopMaximum top_maximum() const override;
  [[nodiscard]] TopRaster raster_top(double x0_m, double y0_m, double dx_m, double dy_m, int nx,
                                     int ny) const override;
  void write_vtu(const std::function<void(std::string_view)>& sink, double time_s) override;
  [[nodiscard]] MeshStats stats() const override;
  [[nodiscard]] double top_z_m() const override { return top_z_; }
  [[nodiscard]] double enthalpy_j() const override;
  [[nodiscard]] double top_area_m2() const override;
  void set_uniform_temperature(double temp_c) override;
  [[nodiscard]] double solve_seconds() const override { return solve_seconds_; }
  void barrier() override { MPI_Barrier(comm_); }

 private:
  void make_mesh();
  void setup_dofs();
  // Per deposited, locally owned cell: what the assembly needs that depends on the mesh only
  // (rebuilt by setup_dofs, which every change of mesh or of the deposited domain calls).
  void build_cell_cache();
  [[nodiscard]] Law law(const Cell& cell) const;
  [[nodiscard]] bool is_active(const Cell& cell) const { return cell->active_fe_index() == kActive; }
  [[nodiscard]] bool is_top_face(const Cell& cell, unsigned f) const;
  [[nodiscard]] double face_tolerance() const { return 1e-6 * spec_.mesh.layer_thickness_m; }
  [[nodiscard]] double loss_flux(double t) const;
  [[nodiscard]] double loss_slope(double t) const;

  struct Sums {
    double enthalpy = 0, loss = 0, radiation = 0, convection = 0;
  };
  // v_h = M H(T) (lumped), v_k = K T + L(T); with `matrix` also J = M H'(T) + tau (K + L').
  Sums assemble(const Vec& t_ghost, double tau, Vec& v_h, Vec& v_k, bool matrix);
  // out = integral of (laser flux + U) phi_i over the top surface; returns (laser, flux) totals.
  std::pair<double, double> assemble_inputs(const StepInput& in, Vec& out);
  // Updates the consolidation states from T; returns (cells changed, enthalpy change).
  std::pair<int, double> update_states();
  [[nodiscard]] double energy_of(const Vec& t_ghost) const;
  // The nodal enthalpy model phi_i(T) = a_i T + b_i max(sigma_i, f(T)) of the lumped mass
  // (a_i = sum of m rho c, b_i = sum of m rho L over the node's cells, sigma_i their mean state
  // weighted by b): exact at a node whose cells share one state.
  void build_nodal_model();
  // Newton's update mapped through the enthalpy: phi_i(T_new) = phi_i(T) + phi_i'(T) delta_i,
  // so a node the linearisation carries across the melting range stops where the latent heat
  // puts it instead of where the heat capacity alone would (Nedjar, 2002). delta is replaced
  // by T_new - T.
  void enthalpy_update(const Vec& t_owned, Vec& delta) const;
  // CG on J x = b to |r| <= rel_tol |b| (at least the configured linear tolerance).
  void solve_linear(Vec& x, const Vec& b, double rel_tol, int& iterations, const char* what);
  [[noreturn]] void fail(const std::string& message) const;
  std::pair<Cell, Point<dim>> locate(const Point<dim>& p) const;

  MPI_Comm comm_ = MPI_COMM_WORLD;
  PlantSpec spec_;
  parallel::distributed::Triangulation<dim> tria_;
  hp::FECollection<dim> fes_;
  DoFHandler<dim> dof_;
  MappingQ1<dim> mapping_;
  IndexSet owned_, relevant_;
  AffineConstraints<double> cons_;
  TrilinosWrappers::SparseMatrix jac_;
  // The conductivity matrix K(s) of the current mesh and states: the Jacobian is
  // tau K + a diagonal (capacities and the losses' slopes), so a Newton iteration adds a
  // diagonal to a scaled copy instead of assembling; K is assembled after a change of mesh and
  // updated cell by cell where the states change.
  TrilinosWrappers::SparseMatrix stiff_;
  bool stiff_valid_ = false;
  void assemble_stiffness();
  Vec t_;  // ghosted temperature
  std::vector<double> state_;  // per active cell index
  std::unique_ptr<GridTools::Cache<dim>> cache_;
  struct CellData {
    Cell cell;
    std::array<types::global_dof_index, 8> dofs;
    std::array<double, 64> k_unit;  // int grad phi_i . grad phi_j (conductivity 1)
    std::array<double, 8> volume;   // Gauss-Lobatto weight of each node (lumped mass / rho c)
    std::array<double, 8> top;      // the same of the top face (0 for the other nodes)
    bool has_top = false;
    bool constrained = false;  // a hanging node among its dofs
  };
  std::vector<CellData> cells_;
  double top_z_ = 0.0;
  int layers_ = 0;
  int step_count_ = 0;
  double solve_seconds_ = 0.0;
  std::uint64_t matrix_version_ = 0;
  std::unique_ptr<TrilinosWrappers::PreconditionAMG> amg_;
  types::global_dof_index amg_dofs_ = 0;
  int amg_age_ = 0;
  // CG iterations per decade of residual reduction right after the AMG hierarchy was built,
  // and in the last solve (the solves ask for different reductions, so the rate compares).
  double amg_rate_ = -1, last_rate_ = 0;
  // The previous step's temperatures (owned), for the predictor; invalid after a change of
  // mesh, of the deposited domain or of the temperatures from outside.
  Vec t_prev_;
  Vec node_a_, node_b_, node_bs_;
  double prev_dt_ = 0.0;
  bool have_prev_ = false;
  // Newton's contraction |R_1|/|R_0| in the last step (sets the first linear tolerance).
  double last_contraction_ = 0.0;
  // Seconds by phase, printed to stderr at the end when AMCTL_SLS3D_PROFILE is set.
  mutable double t_assemble_ = 0, t_assemble_matrix_ = 0, t_linear_ = 0, t_remesh_ = 0, t_setup_ = 0, t_inputs_ = 0, t_amg_ = 0;
  mutable long n_assemble_matrix_ = 0, n_assemble_vector_ = 0, n_amg_ = 0, n_cg_ = 0, n_newton_ = 0, n_predicted_ = 0;

 public:
  ~FePlant() override {
    if (std::getenv("AMCTL_SLS3D_PROFILE") && Utilities::MPI::this_mpi_process(comm_) == 0)
      std::fprintf(stderr,
                   "sls3d profile: assemble %.3f s (%ld with the matrix: %.3f s, %ld vectors only), linear %.3f s "
                   "(%ld CG iterations, AMG setup %.3f s in %ld builds), inputs %.3f s, remesh %.3f s "
                   "(setup %.3f s); %ld Newton iterations, predictor taken in %ld steps\n",
                   t_assemble_, n_assemble_matrix_, t_assemble_matrix_, n_assemble_vector_, t_linear_, n_cg_, t_amg_, n_amg_,
                   t_inputs_, t_remesh_, t_setup_, n_newton_, n_predicted_);
  }
};

inline Law FePlant::law(const Cell& cell) const {
  const double s = state_[cell->active_cell_index()];
  const Material& p = spec_.powder;
  const Material& q = spec_.sintered;
  Law l{};
  l.s = s;
  l.k = p.conductivity_w_mk + s * (q.conductivity_w_mk - p.conductivity_w_mk);
  l.rho_c = p.volumetric_heat_j_m3k() + s * (q.volumetric_heat_j_m3k() - p.volumetric_heat_j_m3k());
  const double rho = p.density_kg_m3 + s * (q.density_kg_m3 - p.density_kg_m3);
  l.melting = spec_.melting.enabled;
  l.rho_l = rho * spec_.melting.latent_heat_j_kg;
  l.solidus = spec_.melting.solidus_c;
  l.width = spec_.melting.liquidus_c - spec_.melting.solidus_c;
  return l;
}

inline bool FePlant::is_top_face(const Cell& cell, unsigned f) const {
  const auto face = cell->face(f);
  for (unsigned v = 0; v < face->n_vertices(); ++v)
    if (std::abs(face->vertex(v)[2] - top_z_) > face_tolerance()) return false;
  return true;
}

inline double FePlant::loss_flux(double t) const {
  const SurfaceLosses& l = spec_.losses;
  double q = l.convection_w_m2k * (t - l.gas_temp_c);
  if (l.emissivity > 0) {
    const double a = t + kKelvin, b = l.radiation_env_c + kKelvin;
    q += l.emissivity * kStefanBoltzmann * (a * a * a * a - b * b * b * b);
  }
  return q;
}
inline double FePlant::loss_slope(double t) const {
  const SurfaceLosses& l = spec_.losses;
  const double a = t + kKelvin;
  return l.convection_w_m2k + 4.0 * l.emissivity * kStefanBoltzmann * a * a * a;
}

}  // namespace amctl::sls3d::fe
