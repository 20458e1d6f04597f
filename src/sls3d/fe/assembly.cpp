// The finite-element plant's assembly (fe_plant.hpp): the lumped enthalpy, the conductivity
// matrix K(s) and the Jacobian tau K + diagonal, the top-surface losses, the laser (resolved
// spot or lumped strips) and the preheating flux, and the consolidation states.
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/timer.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>
#include <deal.II/lac/vector.h>

#include "fe_plant.hpp"

namespace amctl::sls3d::fe {

namespace {

// The laser pass in its own frame: along-track coordinate s in [0, length], across d.
struct PassFrame {
  double x0, y0, ex, ey, length, speed, power, t0, t1;
  double xmin, xmax, ymin, ymax;  // bounding box incl. margin
};

}  // namespace

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

}  // namespace amctl::sls3d::fe
