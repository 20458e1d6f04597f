// The finite-element plant's mesh and domain (fe_plant.hpp): construction, the extruded
// disc or rectangle, the degrees of freedom and the per-cell cache, a new layer of powder
// (add_layer), adaptive refinement with the temperature and the states carried over (remesh),
// MPI start-up and the entry point of the shared library.
#include <deal.II/base/multithread_info.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/distributed/cell_data_transfer.h>
#include <deal.II/distributed/cell_data_transfer.templates.h>
#include <deal.II/distributed/solution_transfer.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_nothing.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparsity_tools.h>
#include <deal.II/numerics/adaptation_strategies.h>

#include <p4est.h>
#include <sc.h>

#include <limits>

#include "fe_plant.hpp"

namespace amctl::sls3d::fe {

namespace {

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

}  // namespace

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

}  // namespace amctl::sls3d::fe

extern "C" __attribute__((visibility("default"))) void amctl_sls3d_make_plant(
    const amctl::sls3d::PlantSpec& spec, std::unique_ptr<amctl::sls3d::Plant>& out) {
  amctl::sls3d::fe::ensure_mpi();
  out = std::make_unique<amctl::sls3d::fe::FePlant>(spec);
}
