// The finite-element plant of the SLS powder bed (docs/sls3d.md): deal.II 9.4 on a
// parallel::distributed::Triangulation (p4est), Q1 elements, the not-yet-spread layers as
// FE_Nothing cells (hp), Trilinos matrices and AMG. This is the only translation unit of amctl
// that includes deal.II; it is built into a shared library loaded on first use
// (src/sls3d/engine_loader.cpp), so the rest of amctl neither compiles nor loads deal.II.
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
#include <deal.II/base/conditional_ostream.h>
#include <deal.II/base/index_set.h>
#include <deal.II/base/mpi.h>
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/cell_data_transfer.h>
#include <deal.II/distributed/cell_data_transfer.templates.h>
#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/distributed/tria.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_nothing.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q1.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/grid_tools_cache.h>
#include <deal.II/grid/tria.h>
#include <deal.II/hp/fe_collection.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/solver_cg.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/lac/trilinos_precondition.h>
#include <deal.II/lac/trilinos_sparse_matrix.h>
#include <deal.II/lac/trilinos_vector.h>
#include <deal.II/numerics/adaptation_strategies.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/rtree.h>

#include <p4est.h>
#include <sc.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <filesystem>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d::fe {
namespace {

using namespace dealii;
constexpr int dim = 3;
using Vec = TrilinosWrappers::MPI::Vector;
using Cell = DoFHandler<dim>::active_cell_iterator;
constexpr double kKelvin = 273.15;
constexpr double kStefanBoltzmann = 5.670374419e-8;
constexpr unsigned kActive = 0, kInactive = 1;

// MPI is initialised by the first plant of the process unless the host did it (and p4est's
// sc library with it, silent), and finalised at exit. Not deal.II's MPI_InitFinalize: its
// destructor releases deal.II's vector pools, which at static-destruction time are already
// gone. One thread per rank.
class MpiSession {
 public:
  MpiSession() {
    int initialised = 0;
    MPI_Initialized(&initialised);
    if (!initialised) {
      MPI_Init(nullptr, nullptr);
      owns_ = true;
    }
    sc_init(MPI_COMM_WORLD, 0, 0, nullptr, SC_LP_SILENT);
    p4est_init(nullptr, SC_LP_SILENT);
    MultithreadInfo::set_thread_limit(1);
  }
  ~MpiSession() {
    int finalised = 0;
    MPI_Finalized(&finalised);
    if (owns_ && !finalised) MPI_Finalize();
  }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

 private:
  bool owns_ = false;
};

void ensure_mpi() { static MpiSession session; }

void sum_in_place(std::vector<double>& v, MPI_Comm comm) {
  MPI_Allreduce(MPI_IN_PLACE, v.data(), int(v.size()), MPI_DOUBLE, MPI_SUM, comm);
}

double smoothstep(double x) {
  if (x <= 0) return 0.0;
  if (x >= 1) return 1.0;
  return x * x * (3.0 - 2.0 * x);
}
double smoothstep_slope(double x) { return (x <= 0 || x >= 1) ? 0.0 : 6.0 * x * (1.0 - x); }

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

// The laser pass in its own frame: along-track coordinate s in [0, length], across d.
struct PassFrame {
  double x0, y0, ex, ey, length, speed, power, t0, t1;
  double xmin, xmax, ymin, ymax;  // bounding box incl. margin
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

FePlant::FePlant(const PlantSpec& spec)
    : spec_(spec),
      tria_(MPI_COMM_WORLD, Triangulation<dim>::limit_level_difference_at_vertices),
      dof_(tria_) {
  fes_.push_back(FE_Q<dim>(1));
  fes_.push_back(FE_Nothing<dim>());
  make_mesh();
  for (const auto& cell : dof_.active_cell_iterators())
    if (cell->is_locally_owned())
      cell->set_active_fe_index(cell->center()[2] < top_z_ ? kActive : kInactive);
  state_.assign(tria_.n_active_cells(), 0.0);
  for (const auto& cell : tria_.active_cell_iterators())
    if (cell->center()[2] < 0.0) state_[cell->active_cell_index()] = spec_.initial_state;
  setup_dofs();
  set_uniform_temperature(spec_.initial_temp_c);
}

void FePlant::make_mesh() {
  const MeshSpec& m = spec_.mesh;
  Triangulation<2> plane;
  if (m.footprint == MeshSpec::Footprint::disc) {
    Triangulation<2> ball;
    GridGenerator::hyper_ball_balanced(ball, Point<2>(), m.disc_radius_m);
    // Refine (with the circular manifold) until the mean cell is no larger than asked, then
    // flatten: the coarse mesh of p4est must have no hanging nodes and no refinement.
    const double area = M_PI * m.disc_radius_m * m.disc_radius_m;
    while (std::sqrt(area / ball.n_active_cells()) > m.coarse_cell_m * 1.0001) ball.refine_global(1);
    GridGenerator::flatten_triangulation(ball, plane);
  } else {
    const unsigned nx = std::max(1, int(std::ceil((m.x1_m - m.x0_m) / m.coarse_cell_m - 1e-9)));
    const unsigned ny = std::max(1, int(std::ceil((m.y1_m - m.y0_m) / m.coarse_cell_m - 1e-9)));
    GridGenerator::subdivided_hyper_rectangle(plane, {nx, ny}, Point<2>(m.x0_m, m.y0_m),
                                              Point<2>(m.x1_m, m.y1_m));
  }
  std::vector<double> z = m.base_slices_m;
  for (int layer = 1; layer <= m.layers; ++layer)
    for (int c = 1; c <= m.cells_per_layer; ++c)
      z.push_back(m.layer_thickness_m * (layer - 1 + double(c) / m.cells_per_layer));
  Triangulation<dim> serial;
  GridGenerator::extrude_triangulation(plane, z, serial);
  tria_.copy_triangulation(serial);
  if (std::getenv("AMCTL_SLS3D_PROFILE") && Utilities::MPI::this_mpi_process(comm_) == 0)
    std::fprintf(stderr, "sls3d mesh: %u coarse cells in the plane, %zu slices, %u coarse cells\n",
                 plane.n_active_cells(), z.size() - 1, serial.n_active_cells());
  top_z_ = 0.0;
  layers_ = 0;
}

void FePlant::setup_dofs() {
  Timer timer;
  dof_.distribute_dofs(fes_);
  owned_ = dof_.locally_owned_dofs();
  DoFTools::extract_locally_relevant_dofs(dof_, relevant_);
  cons_.clear();
  cons_.reinit(relevant_);
  DoFTools::make_hanging_node_constraints(dof_, cons_);
  cons_.close();
  DynamicSparsityPattern dsp(relevant_);
  DoFTools::make_sparsity_pattern(dof_, dsp, cons_, false);
  SparsityTools::distribute_sparsity_pattern(dsp, owned_, comm_, relevant_);
  amg_.reset();
  jac_.reinit(owned_, owned_, dsp, comm_);
  stiff_.reinit(owned_, owned_, dsp, comm_);
  stiff_valid_ = false;
  t_.reinit(owned_, relevant_, comm_);
  have_prev_ = false;
  cache_ = std::make_unique<GridTools::Cache<dim>>(tria_, mapping_);
  build_cell_cache();
  t_setup_ += timer.wall_time();
}

void FePlant::build_cell_cache() {
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  AMCTL_CHECK(n == 8, "sls3d engine: Q1 hexahedra");
  QGaussLobatto<dim> q_lump(2);
  QGauss<dim> q_stiff(2);
  QGaussLobatto<dim - 1> q_face(2);
  FEValues<dim> fv_lump(mapping_, fe, q_lump, update_values | update_JxW_values);
  FEValues<dim> fv_stiff(mapping_, fe, q_stiff, update_gradients | update_JxW_values);
  FEFaceValues<dim> fv_face(mapping_, fe, q_face, update_values | update_JxW_values);
  std::vector<types::global_dof_index> idx(n);
  cells_.clear();
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    CellData d;
    d.cell = cell;
    cell->get_dof_indices(idx);
    std::copy(idx.begin(), idx.end(), d.dofs.begin());
    d.k_unit.fill(0.0);
    d.volume.fill(0.0);
    d.top.fill(0.0);
    fv_lump.reinit(cell);
    for (unsigned q = 0; q < q_lump.size(); ++q)
      for (unsigned i = 0; i < n; ++i) d.volume[i] += fv_lump.shape_value(i, q) * fv_lump.JxW(q);
    fv_stiff.reinit(cell);
    for (unsigned q = 0; q < q_stiff.size(); ++q)
      for (unsigned i = 0; i < n; ++i)
        for (unsigned j = 0; j < n; ++j)
          d.k_unit[i * 8 + j] += fv_stiff.shape_grad(i, q) * fv_stiff.shape_grad(j, q) * fv_stiff.JxW(q);
    for (unsigned f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f) {
      if (!is_top_face(cell, f)) continue;
      d.has_top = true;
      fv_face.reinit(cell, f);
      for (unsigned q = 0; q < q_face.size(); ++q)
        for (unsigned i = 0; i < n; ++i) d.top[i] += fv_face.shape_value(i, q) * fv_face.JxW(q);
    }
    for (unsigned i = 0; i < n; ++i) d.constrained = d.constrained || cons_.is_constrained(d.dofs[i]);
    cells_.push_back(d);
  }
}

Law FePlant::law(const Cell& cell) const {
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

bool FePlant::is_top_face(const Cell& cell, unsigned f) const {
  const auto face = cell->face(f);
  for (unsigned v = 0; v < face->n_vertices(); ++v)
    if (std::abs(face->vertex(v)[2] - top_z_) > face_tolerance()) return false;
  return true;
}

double FePlant::loss_flux(double t) const {
  const SurfaceLosses& l = spec_.losses;
  double q = l.convection_w_m2k * (t - l.gas_temp_c);
  if (l.emissivity > 0) {
    const double a = t + kKelvin, b = l.radiation_env_c + kKelvin;
    q += l.emissivity * kStefanBoltzmann * (a * a * a * a - b * b * b * b);
  }
  return q;
}
double FePlant::loss_slope(double t) const {
  const SurfaceLosses& l = spec_.losses;
  const double a = t + kKelvin;
  return l.convection_w_m2k + 4.0 * l.emissivity * kStefanBoltzmann * a * a * a;
}

void FePlant::assemble_stiffness() {
  FullMatrix<double> cm(8, 8);
  std::vector<types::global_dof_index> idx(8);
  stiff_ = 0;
  for (const CellData& d : cells_) {
    const double k = law(d.cell).k;
    for (unsigned i = 0; i < 8; ++i) {
      idx[i] = d.dofs[i];
      for (unsigned j = 0; j < 8; ++j) cm(i, j) = k * d.k_unit[i * 8 + j];
    }
    cons_.distribute_local_to_global(cm, idx, stiff_);
  }
  stiff_.compress(VectorOperation::add);
  stiff_valid_ = true;
}

FePlant::Sums FePlant::assemble(const Vec& t_ghost, double tau, Vec& v_h, Vec& v_k, bool matrix) {
  Timer timer;
  constexpr unsigned n = 8;
  const bool losses = spec_.losses.emissivity > 0 || spec_.losses.convection_w_m2k > 0;
  const SurfaceLosses& sl = spec_.losses;
  FullMatrix<double> cm(n, n);
  Vector<double> ch(n), ck(n);
  std::array<double, n> tl{};
  std::vector<types::global_dof_index> idx(n);
  Sums sums;
  v_h = 0;
  v_k = 0;
  Vec diagonal;
  if (matrix) {
    if (!stiff_valid_) assemble_stiffness();
    jac_ = 0;
    jac_.add(tau, stiff_);
    diagonal.reinit(owned_, comm_);
  }
  Vector<double> cd(n);
  for (const CellData& d : cells_) {
    const Law lw = law(d.cell);
    for (unsigned i = 0; i < n; ++i) {
      idx[i] = d.dofs[i];
      tl[i] = t_ghost[idx[i]];
    }
    // Lumped enthalpy: at the nodes, weighted by the nodes' volumes.
    for (unsigned i = 0; i < n; ++i) {
      const double h = lw.enthalpy(tl[i]);
      sums.enthalpy += h * d.volume[i];
      ch[i] = h * d.volume[i];
    }
    for (unsigned i = 0; i < n; ++i) {
      double sum = 0;
      for (unsigned j = 0; j < n; ++j) sum += d.k_unit[i * 8 + j] * tl[j];
      ck[i] = lw.k * sum;
    }
    if (matrix)
      for (unsigned i = 0; i < n; ++i) cd[i] = lw.capacity(tl[i]) * d.volume[i];
    if (losses && d.has_top) {
      for (unsigned i = 0; i < n; ++i) {
        if (d.top[i] == 0.0) continue;
        const double loss = loss_flux(tl[i]);
        sums.loss += loss * d.top[i];
        sums.convection += sl.convection_w_m2k * (tl[i] - sl.gas_temp_c) * d.top[i];
        ck[i] += loss * d.top[i];
        if (matrix) cd[i] += tau * loss_slope(tl[i]) * d.top[i];
      }
    }
    if (matrix) {
      if (d.constrained) {  // through the constraints, a diagonal is not diagonal any more
        cm = 0;
        for (unsigned i = 0; i < n; ++i) cm(i, i) = cd[i];
        cons_.distribute_local_to_global(cm, idx, jac_);
      } else {
        diagonal.add(idx, cd);
      }
    }
    cons_.distribute_local_to_global(ch, idx, v_h);
    cons_.distribute_local_to_global(ck, idx, v_k);
  }
  v_h.compress(VectorOperation::add);
  v_k.compress(VectorOperation::add);
  if (matrix) {
    jac_.compress(VectorOperation::add);
    diagonal.compress(VectorOperation::add);
    // Add the diagonal in place (Epetra's row map and the vector's map are both the owned dofs).
    auto& epetra = const_cast<Epetra_CrsMatrix&>(jac_.trilinos_matrix());
    Epetra_Vector diag(epetra.RowMap());
    epetra.ExtractDiagonalCopy(diag);
    AMCTL_CHECK(diag.MyLength() == int(diagonal.locally_owned_size()), "sls3d engine: diagonal layout");
    const double* add = diagonal.begin();
    for (int k = 0; k < diag.MyLength(); ++k) diag[k] += add[k];
    epetra.ReplaceDiagonalValues(diag);
    ++matrix_version_;
    ++n_assemble_matrix_;
    t_assemble_matrix_ += timer.wall_time();
  } else {
    ++n_assemble_vector_;
  }
  sums.enthalpy = Utilities::MPI::sum(sums.enthalpy, comm_);
  sums.loss = Utilities::MPI::sum(sums.loss, comm_);
  sums.convection = Utilities::MPI::sum(sums.convection, comm_);
  sums.radiation = sums.loss - sums.convection;
  t_assemble_ += timer.wall_time();
  return sums;
}

std::pair<double, double> FePlant::assemble_inputs(const StepInput& in, Vec& out) {
  out = 0;
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  std::vector<PassFrame> passes;
  const double w = in.beam_radius_m, hh = 0.5 * in.hatch_m;
  const double margin = in.source == SourceModel::gaussian ? 4.0 * w : hh;
  for (const LaserPass& p : in.passes) {
    PassFrame f{};
    const double dx = p.x1_m - p.x0_m, dy = p.y1_m - p.y0_m;
    f.length = std::hypot(dx, dy);
    f.ex = f.length > 0 ? dx / f.length : 1.0;
    f.ey = f.length > 0 ? dy / f.length : 0.0;
    f.x0 = p.x0_m;
    f.y0 = p.y0_m;
    f.t0 = p.t0_s;
    f.t1 = p.t1_s;
    f.power = p.power_w;
    f.speed = (p.t1_s > p.t0_s) ? f.length / (p.t1_s - p.t0_s) : 0.0;
    f.xmin = std::min(p.x0_m, p.x1_m) - margin;
    f.xmax = std::max(p.x0_m, p.x1_m) + margin;
    f.ymin = std::min(p.y0_m, p.y1_m) - margin;
    f.ymax = std::max(p.y0_m, p.y1_m) + margin;
    if (p.t1_s > p.t0_s && p.power_w > 0) passes.push_back(f);
  }
  const double dt = in.dt_s;
  // The step-averaged laser flux at (x, y), W/m^2.
  auto laser = [&](double x, double y) {
    double q = 0;
    for (const PassFrame& f : passes) {
      if (x < f.xmin || x > f.xmax || y < f.ymin || y > f.ymax) continue;
      const double rx = x - f.x0, ry = y - f.y0;
      const double s = rx * f.ex + ry * f.ey, d = -rx * f.ey + ry * f.ex;
      const double duration = f.t1 - f.t0;
      if (in.source == SourceModel::gaussian) {
        const double peak = 2.0 * f.power / (M_PI * w * w);
        const double across = std::exp(-2.0 * d * d / (w * w));
        if (f.length <= 1e-12 * w) {
          q += peak * across * std::exp(-2.0 * s * s / (w * w)) * duration / dt;
        } else {
          const double a = std::sqrt(2.0) / w;
          const double along = w / f.speed * std::sqrt(M_PI / 8.0) *
                               (std::erf(a * s) - std::erf(a * (s - f.length)));
          q += peak * across * along / dt;
        }
      } else {
        if (s >= 0 && s <= f.length && std::abs(d) <= hh)
          q += f.power * duration / (f.length * in.hatch_m) / dt;
      }
    }
    return q;
  };
  double nominal = 0;
  for (const PassFrame& f : passes) nominal += f.power * (f.t1 - f.t0);
  double laser_total = 0, flux_total = 0;
  Vector<double> cr(n), cl(n);
  std::vector<types::global_dof_index> idx(n);
  QGauss<dim - 1> q_flux(2);
  FEFaceValues<dim> fv_flux(mapping_, fe, q_flux, update_values | update_JxW_values);
  // The laser needs points closer than its scale: an iterated Gauss rule per face.
  const double scale = in.source == SourceModel::gaussian ? 0.25 * w : 0.5 * in.hatch_m;
  std::vector<std::unique_ptr<FEFaceValues<dim>>> fv_laser(17);
  Vec laser_vec;
  laser_vec.reinit(owned_, comm_);
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    for (unsigned f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f) {
      if (!is_top_face(cell, f)) continue;
      cell->get_dof_indices(idx);
      cr = 0;
      cl = 0;
      fv_flux.reinit(cell, f);
      for (unsigned q = 0; q < q_flux.size(); ++q) {
        flux_total += in.top_flux_w_m2 * fv_flux.JxW(q);
        for (unsigned i = 0; i < n; ++i)
          cr[i] += in.top_flux_w_m2 * fv_flux.shape_value(i, q) * fv_flux.JxW(q);
      }
      bool near = false;
      const auto face = cell->face(f);
      const BoundingBox<dim> box = face->bounding_box();
      for (const PassFrame& p : passes)
        if (box.get_boundary_points().first[0] <= p.xmax &&
            box.get_boundary_points().second[0] >= p.xmin &&
            box.get_boundary_points().first[1] <= p.ymax &&
            box.get_boundary_points().second[1] >= p.ymin)
          near = true;
      if (near) {
        const double size = std::max(box.side_length(0), box.side_length(1));
        const int sub = std::clamp(int(std::ceil(size / std::max(scale, 1e-300))), 1, 16);
        if (!fv_laser[sub])
          fv_laser[sub] = std::make_unique<FEFaceValues<dim>>(
              mapping_, fe, QIterated<dim - 1>(QGauss<1>(2), sub),
              update_values | update_JxW_values | update_quadrature_points);
        FEFaceValues<dim>& fl = *fv_laser[sub];
        fl.reinit(cell, f);
        for (unsigned q = 0; q < fl.n_quadrature_points; ++q) {
          const Point<dim>& x = fl.quadrature_point(q);
          const double ql = laser(x[0], x[1]);
          if (ql == 0.0) continue;
          laser_total += ql * fl.JxW(q);
          for (unsigned i = 0; i < n; ++i) cl[i] += ql * fl.shape_value(i, q) * fl.JxW(q);
        }
      }
      cons_.distribute_local_to_global(cr, idx, out);
      cons_.distribute_local_to_global(cl, idx, laser_vec);
    }
  }
  out.compress(VectorOperation::add);
  laser_vec.compress(VectorOperation::add);
  laser_total = Utilities::MPI::sum(laser_total, comm_);
  flux_total = Utilities::MPI::sum(flux_total, comm_);
  // Part scale: the strips as sampled carry exactly the passes' energy.
  if (in.source == SourceModel::lumped_strip && laser_total > 0) {
    const double factor = nominal / (laser_total * dt);
    laser_vec *= factor;
    laser_total *= factor;
  }
  out += laser_vec;
  return {laser_total, flux_total};
}

double FePlant::energy_of(const Vec& t_ghost) const {
  double e = 0;
  for (const CellData& d : cells_) {
    const Law lw = law(d.cell);
    for (unsigned i = 0; i < 8; ++i) e += lw.enthalpy(t_ghost[d.dofs[i]]) * d.volume[i];
  }
  return Utilities::MPI::sum(e, comm_);
}

double FePlant::enthalpy_j() const { return energy_of(t_); }

std::pair<int, double> FePlant::update_states() {
  if (!spec_.melting.enabled) return {0, 0.0};
  int changed = 0;
  double de = 0;
  for (const CellData& d : cells_) {
    Law lw = law(d.cell);
    std::array<double, 8> tn{};
    double fmin = 1.0;
    for (unsigned i = 0; i < 8; ++i) {
      tn[i] = t_[d.dofs[i]];
      fmin = std::min(fmin, lw.fraction(tn[i]));
    }
    // Raising s to the smallest melt fraction of the cell keeps max(s, f) unchanged at every
    // node: only rho c and k change (docs/sls3d.md, "Consolidation").
    if (fmin > lw.s + 1e-12) {
      double before = 0, after = 0;
      for (unsigned i = 0; i < 8; ++i) before += lw.enthalpy(tn[i]) * d.volume[i];
      state_[d.cell->active_cell_index()] = fmin;
      const double k_before = lw.k;
      lw = law(d.cell);
      if (stiff_valid_) {  // K changes in this cell only
        FullMatrix<double> cm(8, 8);
        std::vector<types::global_dof_index> idx(d.dofs.begin(), d.dofs.end());
        for (unsigned i = 0; i < 8; ++i)
          for (unsigned j = 0; j < 8; ++j) cm(i, j) = (lw.k - k_before) * d.k_unit[i * 8 + j];
        cons_.distribute_local_to_global(cm, idx, stiff_);
      }
      for (unsigned i = 0; i < 8; ++i) after += lw.enthalpy(tn[i]) * d.volume[i];
      de += after - before;
      ++changed;
    }
  }
  if (stiff_valid_) stiff_.compress(VectorOperation::add);
  return {int(Utilities::MPI::sum(changed, comm_)), Utilities::MPI::sum(de, comm_)};
}

void FePlant::build_nodal_model() {
  node_a_.reinit(owned_, comm_);
  node_b_.reinit(owned_, comm_);
  node_bs_.reinit(owned_, comm_);
  Vector<double> ca(8), cb(8), cs(8);
  std::vector<types::global_dof_index> idx(8);
  for (const CellData& d : cells_) {
    const Law lw = law(d.cell);
    for (unsigned i = 0; i < 8; ++i) {
      idx[i] = d.dofs[i];
      ca[i] = lw.rho_c * d.volume[i];
      cb[i] = lw.rho_l * d.volume[i];
      cs[i] = lw.rho_l * lw.s * d.volume[i];
    }
    cons_.distribute_local_to_global(ca, idx, node_a_);
    cons_.distribute_local_to_global(cb, idx, node_b_);
    cons_.distribute_local_to_global(cs, idx, node_bs_);
  }
  node_a_.compress(VectorOperation::add);
  node_b_.compress(VectorOperation::add);
  node_bs_.compress(VectorOperation::add);
}

void FePlant::enthalpy_update(const Vec& t_owned, Vec& delta) const {
  const double ts = spec_.melting.solidus_c, w = spec_.melting.liquidus_c - spec_.melting.solidus_c;
  const auto n = std::size_t(delta.locally_owned_size());
  const double* t = t_owned.begin();
  const double* a = node_a_.begin();
  const double* b = node_b_.begin();
  const double* bs = node_bs_.begin();
  double* d = delta.begin();
  for (std::size_t i = 0; i < n; ++i) {
    if (a[i] <= 0.0 || b[i] <= 0.0 || d[i] == 0.0) continue;  // constrained, or no latent heat
    const double sigma = std::clamp(bs[i] / b[i], 0.0, 1.0);
    auto phi = [&](double x) { return a[i] * x + b[i] * std::max(sigma, smoothstep((x - ts) / w)); };
    auto slope = [&](double x) {
      const double f = smoothstep((x - ts) / w);
      return a[i] + (f > sigma ? b[i] * smoothstep_slope((x - ts) / w) / w : 0.0);
    };
    const double target = phi(t[i]) + slope(t[i]) * d[i];
    // phi rises with a slope of at least a_i, and b_i (1 - sigma) at most over the latent range.
    double lo = (target - b[i]) / a[i], hi = (target - b[i] * sigma) / a[i];
    double x = std::clamp(t[i] + d[i], lo, hi);
    for (int k = 0; k < 60 && hi - lo > 1e-12 * (1.0 + std::abs(x)); ++k) {
      const double g = phi(x) - target;
      if (g == 0.0) break;
      (g > 0 ? hi : lo) = x;
      const double next = x - g / slope(x);
      x = (next > lo && next < hi) ? next : 0.5 * (lo + hi);
    }
    d[i] = x - t[i];
  }
}

[[noreturn]] void FePlant::fail(const std::string& message) const {
  std::ostringstream os;
  os << "step " << step_count_ << ": " << message;
  throw Error(os.str());
}

void FePlant::solve_linear(Vec& x, const Vec& b, double rel_tol, int& iterations, const char* what) {
  const double bnorm = b.l2_norm();
  if (bnorm == 0.0) {
    x = 0;
    return;
  }
  Timer timer;
  rel_tol = std::clamp(rel_tol, spec_.solver.linear_rel_tol, 0.1);
  const double tol = rel_tol * bnorm;
  const double decades = -std::log10(rel_tol);
  unsigned last_step = 0;
  double last_residual = 0;
  // CG from zero with `prec`, at most max_it iterations; false when it did not converge.
  auto run = [&](const auto& prec, unsigned max_it) {
    SolverControl control(max_it, tol);
    SolverCG<Vec> cg(control);
    x = 0;
    try {
      cg.solve(jac_, x, b, prec);
      last_step = control.last_step();
      iterations += int(last_step);
      n_cg_ += long(last_step);
      return true;
    } catch (const SolverControl::NoConvergence& e) {
      last_step = e.last_step;
      last_residual = e.last_residual;
      iterations += int(last_step);
      n_cg_ += long(last_step);
      return false;
    }
  };
  const unsigned max_it = unsigned(spec_.solver.max_linear_iterations);
  bool ok = false, rebuilt = false;
  switch (spec_.solver.preconditioner) {
    case SolverSettings::Preconditioner::amg: {
      // The hierarchy is reused while the mesh is unchanged (the Jacobian changes little from
      // step to step) and rebuilt every 25 matrices, when CG converged clearly slower per decade
      // than right after a rebuild, or when it does not converge with the old one within twice
      // that rate (a stale hierarchy costs at most about twice a fresh solve).
      auto rebuild = [&] {
        Timer amg_timer;
        amg_ = std::make_unique<TrilinosWrappers::PreconditionAMG>();
        TrilinosWrappers::PreconditionAMG::AdditionalData data;
        data.elliptic = true;
        data.smoother_sweeps = 2;
        amg_->initialize(jac_, data);
        amg_dofs_ = dof_.n_dofs();
        amg_age_ = 0;
        amg_rate_ = -1;
        rebuilt = true;
        t_amg_ += amg_timer.wall_time();
        ++n_amg_;
      };
      const bool fresh = !amg_ || amg_dofs_ != dof_.n_dofs() || amg_age_ >= 25 ||
                         (amg_rate_ > 0 && last_rate_ > 1.5 * amg_rate_ + 0.5);
      if (fresh) rebuild();
      ++amg_age_;
      const unsigned stale_cap = unsigned(std::ceil(decades * (2.0 * std::max(amg_rate_, 1.0) + 1.0))) + 5;
      ok = run(*amg_, fresh ? max_it : std::min(max_it, stale_cap));
      if (!ok && !fresh) {
        rebuild();
        ok = run(*amg_, max_it);
      }
      break;
    }
    case SolverSettings::Preconditioner::jacobi: {
      TrilinosWrappers::PreconditionJacobi jac;
      jac.initialize(jac_);
      ok = run(jac, max_it);
      break;
    }
    case SolverSettings::Preconditioner::ssor: {
      TrilinosWrappers::PreconditionSSOR ssor;
      ssor.initialize(jac_);
      ok = run(ssor, max_it);
      break;
    }
  }
  if (!ok) {
    std::ostringstream os;
    os << "the linear solver (CG) did not converge for the " << what << ": " << last_step
       << " iterations, residual " << last_residual << " > " << tol << " (|b| = " << bnorm << ")";
    fail(os.str());
  }
  last_rate_ = double(std::max(1u, last_step)) / std::max(decades, 1.0);
  if (rebuilt) amg_rate_ = last_rate_;
  cons_.distribute(x);
  t_linear_ += timer.wall_time();
}

StepReport FePlant::step(const StepInput& in) {
  Timer timer;
  ++step_count_;
  StepReport r;
  const double dt = in.dt_s, theta = in.theta > 0 ? in.theta : spec_.theta;
  Vec b(owned_, comm_), inputs(owned_, comm_), vh(owned_, comm_), vk(owned_, comm_);
  Vec delta(owned_, comm_), res(owned_, comm_), trial(owned_, comm_), base(owned_, comm_);
  Vec step_vec(owned_, comm_), t_try(owned_, relevant_, comm_), ones(owned_, comm_), j_ones(owned_, comm_);
  // The predictor: the last step's change carried on (a linear extrapolation in time), tried
  // when the previous step's temperatures are on the same mesh.
  const bool predict = have_prev_ && prev_dt_ > 0;
  if (spec_.melting.enabled) build_nodal_model();
  // At T^n: v_h, v_k (and the Jacobian, unless the iteration starts at the predictor).
  // b = M H(T^n) - (1 - theta) dt (K T^n + L^n) + dt (S + U).
  const Sums old = assemble(t_, theta * dt, vh, vk, !predict);
  Timer input_timer;
  const auto [laser_rate, flux_rate] = assemble_inputs(in, inputs);
  t_inputs_ += input_timer.wall_time();
  b = vh;
  b.add(-(1.0 - theta) * dt, vk, dt, inputs);
  r.laser_j = laser_rate * dt;
  r.top_flux_j = flux_rate * dt;
  for (const LaserPass& p : in.passes) r.laser_nominal_j += p.power_w * (p.t1_s - p.t0_s);
  // R(T) = M H(T) + theta dt (K T + L(T)) - b.
  auto form_residual = [&] {
    res = vh;
    res.add(theta * dt, vk, -1.0, b);
    return res.l2_norm();
  };
  // Rounding level of the residual (relative to the stored enthalpy, whatever the domain's size).
  const double floor = 1e-13 * std::abs(old.enthalpy) /
                       std::sqrt(std::max<double>(1.0, double(dof_.n_dofs())));
  Sums now = old;
  // The tolerances are relative to the residual at T^n (what the step has to change),
  // whichever guess the iteration starts from.
  double norm = form_residual();
  r.residual_initial = norm;
  const double target = std::max(spec_.solver.newton_rel_tol * norm, floor);
  bool have_matrix = !predict;
  // The step's starting temperatures, kept for the predictor of the next step.
  Vec t_start(owned_, comm_);
  t_start = t_;
  if (predict) {
    trial = t_;
    trial.add(-1.0, t_prev_);
    trial.sadd(dt / prev_dt_, 1.0, t_start);
    t_try = trial;
    const Sums at = assemble(t_try, 0.0, vh, vk, false);
    const double predicted = form_residual();
    if (std::isfinite(predicted) && predicted < norm) {
      t_ = t_try;
      now = at;
      norm = predicted;
      ++n_predicted_;
    } else {
      norm = r.residual_initial;  // the loop assembles at T^n with the Jacobian
    }
  }
  // Energy scale of the step: what enters and leaves. The step has converged when |R| is
  // below the target, or when it is 1e-5 of where it started (the temperatures then carry a
  // 1e-5 share of the step's change) and the energy defect sum_i R_i (what the balance of
  // the step misses) is below 1e-7 of that scale (the balance is asked to 1e-6).
  const double energy_scale = dt * (std::abs(laser_rate) + std::abs(flux_rate) + std::abs(old.loss)) +
                              1e-15 * std::abs(old.enthalpy);
  auto converged = [&] {
    if (norm <= target) return true;
    if (norm > 1e-5 * r.residual_initial) return false;
    const double defect = res.mean_value() * double(res.size());
    return std::abs(defect) <= 1e-7 * energy_scale;
  };
  int it = 0;
  const bool trace = std::getenv("AMCTL_SLS3D_PROFILE") != nullptr && Utilities::MPI::this_mpi_process(comm_) == 0;
  // Inexact Newton (Eisenstat and Walker's second choice of forcing term): the linear solve
  // asks for a reduction eta = 0.9 (|R_k| / |R_k-1|)^2, never more than 0.1 nor below what
  // the Newton target needs; the first iteration takes the contraction of the last step's
  // first (a step without latent heat is almost linear: one tight solve; a melting step is not).
  double previous_norm = 0.0, eta = 0.0;
  while (!converged()) {
    if (it >= spec_.solver.max_newton_iterations) {
      std::ostringstream os;
      os << "t = " << in.t_s + dt << " s: Newton did not converge in " << it
         << " iterations, residual " << norm << " J > " << target << " J (initial " << r.residual_initial
         << " J)";
      fail(os.str());
    }
    if (!have_matrix) {
      now = assemble(t_, theta * dt, vh, vk, true);
      norm = form_residual();
    }
    if (it == 0) {
      eta = last_contraction_ > 0 ? 0.9 * last_contraction_ * last_contraction_ : 0.0;
    } else {
      const double ew = 0.9 * (norm / previous_norm) * (norm / previous_norm);
      eta = 0.9 * eta * eta > 0.1 ? std::max(ew, 0.9 * eta * eta) : ew;
    }
    eta = std::min(eta, 0.1);
    eta = std::max(eta, 0.5 * target / norm);
    res *= -1.0;
    delta = 0;
    solve_linear(delta, res, eta, r.linear_iterations, "Newton update");
    // An inexact solve leaves a residual whose sum is an energy defect of the step. The rows of
    // K sum to zero, so a uniform shift c of the update changes that sum by c 1'J1 only (the
    // capacities and the losses' slopes): shifted so that the linearised step conserves energy
    // exactly, whatever the linear tolerance (hanging nodes take the shift with their masters).
    {
      ones = 1.0;
      jac_.vmult(j_ones, ones);
      jac_.vmult(trial, delta);
      trial -= res;  // J delta - (-R) : the linear solve's residual
      cons_.set_zero(j_ones);
      cons_.set_zero(trial);
      const double capacity = j_ones.mean_value() * double(j_ones.size());
      const double defect = trial.mean_value() * double(trial.size());
      if (capacity > 0) delta.add(-defect / capacity, ones);
    }
    // Backtracking on |R|: the latent heat makes H' jump at the melting range.
    double lambda = 1.0, next = 0;
    base = t_;
    for (int k = 0; k < 8; ++k) {
      trial = base;
      if (spec_.melting.enabled) {
        // Along the enthalpy: lambda shortens the linear update before it is mapped.
        step_vec = delta;
        step_vec *= lambda;
        enthalpy_update(base, step_vec);
        cons_.distribute(step_vec);  // hanging nodes follow their masters
        trial += step_vec;
      } else {
        trial.add(lambda, delta);
      }
      t_try = trial;
      now = assemble(t_try, 0.0, vh, vk, false);
      next = form_residual();
      if (std::isfinite(next) && (next < norm || k == 7)) break;
      lambda *= 0.5;
    }
    if (!std::isfinite(next)) {
      std::ostringstream os;
      os << "t = " << in.t_s + dt << " s: the Newton update diverged (residual not finite)";
      fail(os.str());
    }
    t_ = t_try;
    if (trace)
      std::fprintf(stderr, "  step %d newton %d: |R| %.3e -> %.3e (lambda %g, eta %.1e, %d CG total)\n", step_count_,
                   it, norm, next, lambda, eta, r.linear_iterations);
    if (it == 0) last_contraction_ = next / norm;
    previous_norm = norm;
    norm = next;
    have_matrix = false;
    ++it;
    ++n_newton_;
  }
  t_prev_ = t_start;
  prev_dt_ = dt;
  have_prev_ = true;
  r.newton_iterations = it;
  r.residual_final = norm;
  r.enthalpy_change_j = now.enthalpy - old.enthalpy;
  r.radiation_j = dt * (theta * now.radiation + (1 - theta) * old.radiation);
  r.convection_j = dt * (theta * now.convection + (1 - theta) * old.convection);
  const double losses = r.radiation_j + r.convection_j;
  r.balance_error_j = r.enthalpy_change_j - (r.laser_j + r.top_flux_j - losses);
  // Relative to the energy that moved in the step; when next to nothing moves (a flux through
  // zero), to the rounding of the stored enthalpy (the balance cannot be closer than that).
  const double scale = std::max(std::abs(r.enthalpy_change_j) + std::abs(r.laser_j) +
                                    std::abs(r.top_flux_j) + std::abs(losses),
                                1e-12 * std::abs(old.enthalpy));
  r.balance_rel_error = scale > 0 ? std::abs(r.balance_error_j) / scale : 0.0;
  const auto [changed, de] = update_states();
  r.cells_consolidated = changed;
  r.densification_j = de;
  double tmax = -std::numeric_limits<double>::infinity();
  for (const auto i : owned_) tmax = std::max(tmax, double(t_[i]));
  r.max_temp_c = Utilities::MPI::max(tmax, comm_);
  solve_seconds_ += timer.wall_time();
  return r;
}

void FePlant::set_uniform_temperature(double temp_c) {
  Vec v(owned_, comm_);
  v = temp_c;
  t_ = v;
  have_prev_ = false;
}

LayerReport FePlant::add_layer(double fresh_temp_c) {
  if (layers_ >= spec_.mesh.layers) throw InternalError("sls3d: no layer left to add");
  const double e_before = enthalpy_j();
  // The old temperatures by vertex (Q1: one node per vertex).
  std::vector<double> by_vertex(tria_.n_vertices(), std::numeric_limits<double>::quiet_NaN());
  for (const auto& cell : dof_.active_cell_iterators())
    if (!cell->is_artificial() && is_active(cell))
      for (unsigned v = 0; v < cell->n_vertices(); ++v)
        by_vertex[cell->vertex_index(v)] = t_[cell->vertex_dof_index(v, 0, kActive)];
  const double z0 = top_z_, z1 = top_z_ + spec_.mesh.layer_thickness_m;
  auto in_layer = [&](const Cell& c) { return c->center()[2] > z0 && c->center()[2] < z1; };
  for (const auto& cell : dof_.active_cell_iterators())
    if (cell->is_locally_owned() && in_layer(cell)) {
      cell->set_active_fe_index(kActive);
      state_[cell->active_cell_index()] = 0.0;
    }
  top_z_ = z1;
  setup_dofs();
  // Lumped capacities of each node from the old and the new cells.
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  QGaussLobatto<dim> q_lump(2);
  FEValues<dim> fv(mapping_, fe, q_lump, update_values | update_JxW_values);
  std::vector<types::global_dof_index> idx(n);
  Vec m_old(owned_, comm_), m_new(owned_, comm_);
  Vector<double> cm(n);
  double fresh = 0;
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    const Law lw = law(cell);
    fv.reinit(cell);
    cm = 0;
    for (unsigned q = 0; q < q_lump.size(); ++q)
      for (unsigned i = 0; i < n; ++i) cm[i] += lw.rho_c * fv.shape_value(i, q) * fv.JxW(q);
    if (in_layer(cell))
      for (unsigned q = 0; q < q_lump.size(); ++q) fresh += lw.enthalpy(fresh_temp_c) * fv.JxW(q);
    cell->get_dof_indices(idx);
    cons_.distribute_local_to_global(cm, idx, in_layer(cell) ? m_new : m_old);
  }
  m_old.compress(VectorOperation::add);
  m_new.compress(VectorOperation::add);
  Vec t(owned_, comm_);
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    for (unsigned v = 0; v < cell->n_vertices(); ++v) {
      const auto i = cell->vertex_dof_index(v, 0, kActive);
      if (!owned_.is_element(i) || cons_.is_constrained(i)) continue;
      const double old = by_vertex[cell->vertex_index(v)];
      const double mo = m_old[i], mn = m_new[i];
      t[i] = (std::isnan(old) || mo <= 0) ? fresh_temp_c : (mo * old + mn * fresh_temp_c) / (mo + mn);
    }
  }
  t.compress(VectorOperation::insert);
  cons_.distribute(t);
  t_ = t;
  ++layers_;
  LayerReport r;
  r.layer = layers_;
  r.top_z_m = top_z_;
  r.enthalpy_change_j = enthalpy_j() - e_before;
  r.fresh_enthalpy_j = Utilities::MPI::sum(fresh, comm_);
  return r;
}

RemeshReport FePlant::remesh(const std::vector<RefineZone>& zones) {
  Timer timer;
  RemeshReport r;
  const double e_before = enthalpy_j();
  const int max_target = [&] {
    int m = 0;
    for (const RefineZone& z : zones) m = std::max(m, z.level);
    return m;
  }();
  for (int pass = 0; pass <= max_target + 2; ++pass) {
    int flagged = 0;
    for (const auto& cell : tria_.active_cell_iterators()) {
      if (!cell->is_locally_owned()) continue;
      const Point<dim> c = cell->center();
      double zmax = -std::numeric_limits<double>::infinity(), half = 0;
      for (unsigned v = 0; v < cell->n_vertices(); ++v) {
        zmax = std::max(zmax, cell->vertex(v)[2]);
        half = std::max(half, std::hypot(cell->vertex(v)[0] - c[0], cell->vertex(v)[1] - c[1]));
      }
      int target = 0;
      for (const RefineZone& z : zones) {
        if (zmax < top_z_ - z.depth_m - face_tolerance()) continue;
        bool touches = false;
        if (z.shape == RefineZone::Shape::annulus) {
          const double rc = std::hypot(c[0], c[1]);
          touches = rc + half >= z.r0_m && rc - half <= z.r1_m;
        } else {
          const double dx = z.x1_m - z.x0_m, dy = z.y1_m - z.y0_m, l2 = dx * dx + dy * dy;
          double u = l2 > 0 ? ((c[0] - z.x0_m) * dx + (c[1] - z.y0_m) * dy) / l2 : 0.0;
          u = std::clamp(u, 0.0, 1.0);
          touches = std::hypot(c[0] - z.x0_m - u * dx, c[1] - z.y0_m - u * dy) <= z.radius_m + half;
        }
        if (touches) target = std::max(target, z.level);
      }
      // Refine towards the target in every pass; coarsen one level in the first only (the
      // 2:1 balance may keep a cell finer than its target, and asking again would loop).
      if (cell->level() < target) {
        cell->set_refine_flag();
        ++flagged;
      } else if (pass == 0 && cell->level() > target) {
        cell->set_coarsen_flag();
        ++flagged;
      }
    }
    if (Utilities::MPI::sum(flagged, comm_) == 0) break;
    tria_.prepare_coarsening_and_refinement();
    parallel::distributed::SolutionTransfer<dim, Vec> st(dof_);
    st.prepare_for_coarsening_and_refinement(t_);
    parallel::distributed::CellDataTransfer<dim, dim, std::vector<double>> cdt(
        tria_, false, &AdaptationStrategies::Refinement::preserve<dim, dim, double>,
        &AdaptationStrategies::Coarsening::mean<dim, dim, double>);
    cdt.prepare_for_coarsening_and_refinement(state_);
    tria_.execute_coarsening_and_refinement();
    setup_dofs();
    Vec t(owned_, comm_);
    st.interpolate(t);
    cons_.distribute(t);
    t_ = t;
    state_.assign(tria_.n_active_cells(), 0.0);
    cdt.unpack(state_);
    r.changed = true;
    ++r.passes;
  }
  r.enthalpy_change_j = r.changed ? enthalpy_j() - e_before : 0.0;
  t_remesh_ += timer.wall_time();
  return r;
}

double FePlant::top_mean(const TopWeight& w) const {
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  QGauss<dim - 1> qf(3);
  FEFaceValues<dim> fv(mapping_, fe, qf, update_values | update_JxW_values | update_quadrature_points);
  std::vector<types::global_dof_index> idx(n);
  double num = 0, den = 0;
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    for (unsigned f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f) {
      if (!is_top_face(cell, f)) continue;
      cell->get_dof_indices(idx);
      fv.reinit(cell, f);
      for (unsigned q = 0; q < qf.size(); ++q) {
        const Point<dim>& x = fv.quadrature_point(q);
        const double r = std::hypot(x[0] - w.x_m, x[1] - w.y_m);
        double weight = 0;
        if (w.kind == TopWeight::Kind::spot)
          weight = std::exp(-2.0 * r * r / (w.radius_m * w.radius_m));
        else
          weight = (r >= w.r0_m && r <= w.r1_m) ? 1.0 : 0.0;
        if (weight == 0.0) continue;
        double tq = 0;
        for (unsigned j = 0; j < n; ++j) tq += fv.shape_value(j, q) * t_[idx[j]];
        num += weight * tq * fv.JxW(q);
        den += weight * fv.JxW(q);
      }
    }
  }
  num = Utilities::MPI::sum(num, comm_);
  den = Utilities::MPI::sum(den, comm_);
  return den > 0 ? num / den : std::numeric_limits<double>::quiet_NaN();
}

double FePlant::top_area_m2() const {
  QGauss<dim - 1> qf(2);
  FEFaceValues<dim> fv(mapping_, fes_[kActive], qf, update_JxW_values);
  double a = 0;
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    for (unsigned f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f) {
      if (!is_top_face(cell, f)) continue;
      fv.reinit(cell, f);
      for (unsigned q = 0; q < qf.size(); ++q) a += fv.JxW(q);
    }
  }
  return Utilities::MPI::sum(a, comm_);
}

std::pair<Cell, Point<dim>> FePlant::locate(const Point<dim>& p) const {
  // Only this rank's cells, found through the cached R-tree of their bounding boxes: a point
  // owned by another rank, or off the disc (the corners of a square map), costs a tree query
  // instead of deal.II's exhaustive fallback search and its exceptions.
  namespace bgi = boost::geometry::index;
  std::vector<std::pair<BoundingBox<dim>, Triangulation<dim>::active_cell_iterator>> hits;
  cache_->get_locally_owned_cell_bounding_boxes_rtree().query(bgi::intersects(p), std::back_inserter(hits));
  // A point on a face between a deposited cell and one above the top goes to the deposited one.
  std::pair<Cell, Point<dim>> found{dof_.end(), Point<dim>()};
  for (const auto& [box, tcell] : hits) {
    try {
      const Point<dim> unit = mapping_.transform_real_to_unit_cell(tcell, p);
      if (!GeometryInfo<dim>::is_inside_unit_cell(unit, 1e-10)) continue;
      const Cell cell(&tria_, tcell->level(), tcell->index(), &dof_);
      if (is_active(cell)) return {cell, GeometryInfo<dim>::project_to_unit_cell(unit)};
      if (found.first == dof_.end()) found = {cell, GeometryInfo<dim>::project_to_unit_cell(unit)};
    } catch (const Mapping<dim>::ExcTransformationFailed&) {
    }
  }
  return found;
}

std::vector<double> FePlant::evaluate(const std::vector<std::array<double, 3>>& points_m) const {
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  std::vector<types::global_dof_index> idx(n);
  std::vector<double> sum(points_m.size(), 0.0), count(points_m.size(), 0.0);
  for (std::size_t k = 0; k < points_m.size(); ++k) {
    const Point<dim> p(points_m[k][0], points_m[k][1], points_m[k][2]);
    const auto [cell, unit] = locate(p);
    if (cell == dof_.end() || !cell->is_locally_owned() || !is_active(cell)) continue;
    cell->get_dof_indices(idx);
    double v = 0;
    for (unsigned j = 0; j < n; ++j) v += t_[idx[j]] * fe.shape_value(j, unit);
    sum[k] += v;
    count[k] += 1;
  }
  sum_in_place(sum, comm_);
  sum_in_place(count, comm_);
  std::vector<double> out(points_m.size());
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = count[k] > 0 ? sum[k] / count[k] : std::numeric_limits<double>::quiet_NaN();
  return out;
}

TopMaximum FePlant::top_maximum() const {
  struct {
    double value;
    int rank;
  } local{-std::numeric_limits<double>::infinity(), int(Utilities::MPI::this_mpi_process(comm_))},
      global{};
  Point<dim> where;
  double size = 0;
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned() || !is_active(cell)) continue;
    for (unsigned f = 0; f < GeometryInfo<dim>::faces_per_cell; ++f) {
      if (!is_top_face(cell, f)) continue;
      const auto face = cell->face(f);
      for (unsigned v = 0; v < face->n_vertices(); ++v) {
        const double t = t_[face->vertex_dof_index(v, 0, kActive)];
        if (t > local.value) {
          local.value = t;
          where = face->vertex(v);
          const BoundingBox<dim> b = face->bounding_box();
          size = std::min(b.side_length(0), b.side_length(1));
        }
      }
    }
  }
  MPI_Allreduce(&local, &global, 1, MPI_DOUBLE_INT, MPI_MAXLOC, comm_);
  double buf[4] = {where[0], where[1], where[2], size};
  MPI_Bcast(buf, 4, MPI_DOUBLE, global.rank, comm_);
  TopMaximum m;
  m.temp_c = global.value;
  m.where_m = {buf[0], buf[1], buf[2]};
  m.cell_size_m = buf[3];
  return m;
}

TopRaster FePlant::raster_top(double x0_m, double y0_m, double dx_m, double dy_m, int nx,
                              int ny) const {
  TopRaster r;
  r.x0_m = x0_m;
  r.y0_m = y0_m;
  r.dx_m = dx_m;
  r.dy_m = dy_m;
  r.nx = nx;
  r.ny = ny;
  const std::size_t np = std::size_t(nx) * std::size_t(ny);
  const FiniteElement<dim>& fe = fes_[kActive];
  const unsigned n = fe.n_dofs_per_cell();
  std::vector<types::global_dof_index> idx(n);
  std::vector<double> sum(2 * np, 0.0), count(np, 0.0);
  // Just below the surface, so the point lies in a deposited cell and not in the one above.
  const double z = top_z_ - 1e-3 * spec_.mesh.layer_thickness_m / spec_.mesh.cells_per_layer;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const std::size_t k = std::size_t(j) * nx + i;
      const Point<dim> p(x0_m + i * dx_m, y0_m + j * dy_m, z);
      const auto [cell, unit] = locate(p);
      if (cell == dof_.end() || !cell->is_locally_owned() || !is_active(cell)) continue;
      cell->get_dof_indices(idx);
      double v = 0;
      for (unsigned m = 0; m < n; ++m) v += t_[idx[m]] * fe.shape_value(m, unit);
      sum[k] += v;
      sum[np + k] += state_[cell->active_cell_index()];
      count[k] += 1;
    }
  sum_in_place(sum, comm_);
  sum_in_place(count, comm_);
  r.temp_c.resize(np);
  r.state.resize(np);
  for (std::size_t k = 0; k < np; ++k) {
    r.temp_c[k] = count[k] > 0 ? sum[k] / count[k] : std::numeric_limits<double>::quiet_NaN();
    r.state[k] = count[k] > 0 ? float(sum[np + k] / count[k]) : 0.0f;
  }
  return r;
}

// DataOut with the names of its data sets readable (protected in deal.II), so the pieces of
// a distributed snapshot can be written by amctl's own output writer.
class SnapshotOut : public DataOut<dim> {
 public:
  using DataOut<dim>::get_dataset_names;
  using DataOut<dim>::get_nonscalar_data_ranges;
};

void FePlant::write_vtu(const std::function<void(std::string_view)>& sink, double time_s) {
  SnapshotOut out;
  out.attach_dof_handler(dof_);
  out.set_cell_selection([this](const Triangulation<dim>::cell_iterator& c) {
    if (!c->is_active() || !c->is_locally_owned()) return false;
    return Cell(&tria_, c->level(), c->index(), &dof_)->active_fe_index() == kActive;
  });
  out.add_data_vector(t_, "temperature_c");
  Vector<float> state(tria_.n_active_cells()), k(tria_.n_active_cells()), rank(tria_.n_active_cells());
  for (const auto& cell : dof_.active_cell_iterators()) {
    if (!cell->is_locally_owned()) continue;
    const auto i = cell->active_cell_index();
    state[i] = float(state_[i]);
    k[i] = float(law(cell).k);
    rank[i] = float(tria_.locally_owned_subdomain());
  }
  out.add_data_vector(state, "consolidation", DataOut<dim>::type_cell_data);
  out.add_data_vector(k, "conductivity_w_mk", DataOut<dim>::type_cell_data);
  out.add_data_vector(rank, "rank", DataOut<dim>::type_cell_data);
  out.build_patches();
  DataOutBase::VtkFlags flags;
  flags.time = time_s;
  flags.compression_level = DataOutBase::VtkFlags::ZlibCompressionLevel::best_speed;
  flags.print_date_and_time = false;  // the same input gives the same file
  // One .vtu for all ranks, laid out as deal.II's write_vtu_in_parallel lays it out (the
  // header, each rank's piece in rank order, the footer), the bytes handed to the host's sink
  // on rank 0, which receives one piece at a time (it holds at most the largest piece).
  std::ostringstream piece;
  DataOutBase::VtkFlags piece_flags = flags;
  // The time goes once into the file (write_vtu_main writes it before its piece): rank 0's.
  if (Utilities::MPI::this_mpi_process(comm_) != 0) piece_flags.time = std::numeric_limits<double>::min();
  DataOutBase::write_vtu_main(out.get_patches(), out.get_dataset_names(), out.get_nonscalar_data_ranges(),
                              piece_flags, piece);
  const std::string mine = piece.str();
  const int rank_id = int(Utilities::MPI::this_mpi_process(comm_));
  const int ranks = int(Utilities::MPI::n_mpi_processes(comm_));
  constexpr int kTagSize = 7301, kTagBytes = 7302;
  constexpr unsigned long long kChunk = 1ull << 30;
  if (rank_id == 0) {
    std::exception_ptr error;
    auto give = [&](std::string_view bytes, bool end = false) {
      if (error || (bytes.empty() && !end)) return;  // an empty view means the end only
      try {
        sink(bytes);
      } catch (...) {
        error = std::current_exception();
      }
    };
    std::ostringstream head;
    DataOutBase::write_vtu_header(head, flags);
    give(head.str());
    give(mine);
    std::string buffer;
    for (int r = 1; r < ranks; ++r) {
      unsigned long long size = 0;
      MPI_Recv(&size, 1, MPI_UNSIGNED_LONG_LONG, r, kTagSize, comm_, MPI_STATUS_IGNORE);
      buffer.resize(size);
      for (unsigned long long at = 0; at < size; at += kChunk)
        MPI_Recv(buffer.data() + at, int(std::min(size - at, kChunk)), MPI_CHAR, r, kTagBytes, comm_,
                 MPI_STATUS_IGNORE);
      give(buffer);
    }
    std::ostringstream foot;
    DataOutBase::write_vtu_footer(foot);
    give(foot.str());
    give(std::string_view(), true);
    int failed = error ? 1 : 0;
    MPI_Bcast(&failed, 1, MPI_INT, 0, comm_);
    if (error) std::rethrow_exception(error);
  } else {
    unsigned long long size = mine.size();
    MPI_Send(&size, 1, MPI_UNSIGNED_LONG_LONG, 0, kTagSize, comm_);
    for (unsigned long long at = 0; at < size; at += kChunk)
      MPI_Send(mine.data() + at, int(std::min(size - at, kChunk)), MPI_CHAR, 0, kTagBytes, comm_);
    int failed = 0;
    MPI_Bcast(&failed, 1, MPI_INT, 0, comm_);
    if (failed) throw Error("the VTU snapshot could not be written (see rank 0's error)");
  }
}

MeshStats FePlant::stats() const {
  MeshStats s;
  s.cells = tria_.n_global_active_cells();
  std::uint64_t active = 0;
  for (const auto& cell : dof_.active_cell_iterators())
    if (cell->is_locally_owned() && is_active(cell)) ++active;
  s.active_cells = Utilities::MPI::sum(active, comm_);
  s.dofs = dof_.n_dofs();
  s.max_level = int(tria_.n_global_levels()) - 1;
  s.ranks = int(Utilities::MPI::n_mpi_processes(comm_));
  s.rank = int(Utilities::MPI::this_mpi_process(comm_));
  s.layers = layers_;
  return s;
}

}  // namespace
}  // namespace amctl::sls3d::fe

extern "C" __attribute__((visibility("default"))) void amctl_sls3d_make_plant(
    const amctl::sls3d::PlantSpec& spec, std::unique_ptr<amctl::sls3d::Plant>& out) {
  amctl::sls3d::fe::ensure_mpi();
  out = std::make_unique<amctl::sls3d::fe::FePlant>(spec);
}
