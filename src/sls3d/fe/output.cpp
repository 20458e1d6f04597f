// The finite-element plant's outputs (fe_plant.hpp): point location through the R-tree of the
// rank's cells, values at points, top-surface means, the maximum and maps, and the VTU
// snapshot of all ranks handed to the host's writer.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/rtree.h>

#include <exception>
#include <limits>
#include <sstream>

#include "fe_plant.hpp"

namespace amctl::sls3d::fe {

namespace {

// DataOut with the names of its data sets readable (protected in deal.II), so the pieces of
// a distributed snapshot can be written by amctl's own output writer.
class SnapshotOut : public DataOut<dim> {
 public:
  using DataOut<dim>::get_dataset_names;
  using DataOut<dim>::get_nonscalar_data_ranges;
};

}  // namespace

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

}  // namespace amctl::sls3d::fe
