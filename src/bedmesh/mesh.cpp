// The mesh's upsampling and lookup (docs/bedmesh.md, sections 1-2). The order of the
// floating-point operations follows the equations as Klipper evaluates them (x rows with
// probes first, then every column along y; the same lerp), so that the z of a point agrees
// with Klipper's to the last bit on the inputs tested.
#include "amctl/bedmesh/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/format.h>

namespace amctl::bedmesh {

const char* name(Algorithm a) {
  switch (a) {
    case Algorithm::lagrange: return "lagrange";
    case Algorithm::bicubic: return "bicubic";
    case Algorithm::direct: return "direct";
  }
  return "?";
}

ZMesh::Axis::Index ZMesh::Axis::locate(double c) const noexcept {
  const double f = std::floor((c - min) / dist);
  int i = 0;
  if (f >= static_cast<double>(count - 2)) {
    i = count - 2;
  } else if (f > 0.0) {
    i = static_cast<int>(f);
  }
  double t = (c - (min + dist * i)) / dist;
  t = std::min(1.0, std::max(0.0, t));
  return {i, t};
}

ZMesh::ZMesh(const Profile& p) : name_(p.name) {
  const MeshParams& m = p.params;
  const bool upsample = m.algo != Algorithm::direct;
  const int x_pps = upsample ? m.mesh_x_pps : 0;
  const int y_pps = upsample ? m.mesh_y_pps : 0;
  // What the printer.cfg reader checks at each key, again for a profile made in code.
  const auto refuse = [&](const std::string& what) {
    throw Error(p.where, fmt::format("bed mesh profile '{}': {}", p.name, what));
  };
  if (m.x_count < 2 || m.y_count < 2 || m.x_count > kMaxFineCount || m.y_count > kMaxFineCount) {
    refuse(fmt::format("found {} x {} probes, expected 2 to {} along each axis", m.x_count, m.y_count,
                       kMaxFineCount));
  }
  if (x_pps < 0 || y_pps < 0 || x_pps > kMaxFineCount || y_pps > kMaxFineCount) {
    refuse(fmt::format("found mesh_x_pps {} and mesh_y_pps {}, expected 0 to {}", x_pps, y_pps, kMaxFineCount));
  }
  const std::int64_t fine_x = std::int64_t{m.x_count - 1} * x_pps + m.x_count;
  const std::int64_t fine_y = std::int64_t{m.y_count - 1} * y_pps + m.y_count;
  if (fine_x > kMaxFineCount || fine_y > kMaxFineCount || fine_x * fine_y > kMaxFinePoints) {
    refuse(fmt::format("found an upsampled mesh of {} x {} points, expected at most {} along an axis and "
                       "{} in all",
                       fine_x, fine_y, kMaxFineCount, kMaxFinePoints));
  }
  if (p.points_mm.size() != static_cast<std::size_t>(m.x_count) * static_cast<std::size_t>(m.y_count)) {
    refuse(fmt::format("found {} probed points, expected x_count * y_count = {}", p.points_mm.size(),
                       static_cast<std::size_t>(m.x_count) * static_cast<std::size_t>(m.y_count)));
  }
  for (const double z : p.points_mm) {
    if (!std::isfinite(z)) refuse(fmt::format("found a probed z of {}, expected a finite number", z));
  }
  if (!(m.max_x_mm > m.min_x_mm && m.max_y_mm > m.min_y_mm && std::isfinite(m.max_x_mm - m.min_x_mm) &&
        std::isfinite(m.max_y_mm - m.min_y_mm))) {
    refuse(fmt::format("found x {}..{}, y {}..{} mm, expected finite extents with min below max",
                       m.min_x_mm, m.max_x_mm, m.min_y_mm, m.max_y_mm));
  }
  if (m.algo == Algorithm::bicubic && (x_pps > 0 || y_pps > 0) && std::min(m.x_count, m.y_count) < 3) {
    refuse(fmt::format("bicubic needs at least 3 probed points along each axis, found {} x {}", m.x_count,
                       m.y_count));
  }
  if (m.algo == Algorithm::bicubic && !(m.tension >= 0.0 && m.tension <= 2.0)) {
    refuse(fmt::format("found tension {}, expected 0 to 2", m.tension));
  }
  x_.count = (m.x_count - 1) * x_pps + m.x_count;
  y_.count = (m.y_count - 1) * y_pps + m.y_count;
  x_mult_ = x_pps + 1;
  y_mult_ = y_pps + 1;
  x_.min = m.min_x_mm;
  y_.min = m.min_y_mm;
  x_.dist = (m.max_x_mm - m.min_x_mm) / (x_.count - 1);
  y_.dist = (m.max_y_mm - m.min_y_mm) / (y_.count - 1);
  grid_.assign(static_cast<std::size_t>(x_.count) * y_.count, 0.0);
  for (int j = 0; j < m.y_count; ++j) {
    for (int i = 0; i < m.x_count; ++i) {
      grid_[static_cast<std::size_t>(j * y_mult_) * x_.count + i * x_mult_] =
          p.points_mm[static_cast<std::size_t>(j) * m.x_count + i];
    }
  }
  if (!upsample) return;
  if (m.algo == Algorithm::lagrange) {
    sample_lagrange(p);
  } else {
    sample_bicubic(p);
  }
}

namespace {

/// Lagrange's polynomial through (nodes[k], value(k)) evaluated at c.
template <class Value>
double lagrange(const std::vector<double>& nodes, double c, Value&& value) {
  double total = 0.0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    double n = 1.0, d = 1.0;
    for (std::size_t j = 0; j < nodes.size(); ++j) {
      if (j == i) continue;
      n *= (c - nodes[j]);
      d *= (nodes[i] - nodes[j]);
    }
    total += value(i) * n / d;
  }
  return total;
}

/// The cardinal spline between p1 and p2 at t in [0, 1], tangents tension * (p2 - p0) and
/// tension * (p3 - p1) (cubic Hermite basis).
double cardinal(double p0, double p1, double p2, double p3, double t, double tension) {
  const double t2 = t * t;
  const double t3 = t2 * t;
  const double m1 = tension * (p2 - p0);
  const double m2 = tension * (p3 - p1);
  const double a = p1 * (2 * t3 - 3 * t2 + 1);
  const double b = p2 * (-2 * t3 + 3 * t2);
  const double c = m1 * (t3 - 2 * t2 + t);
  const double d = m2 * (t3 - t2);
  return a + b + c + d;
}

/// Control points and t of fine index k on a line of `count` fine points with probes every
/// `mult`; `at(k)` reads the line. Ends repeat the end probe.
template <class At>
double spline_at(int k, int count, int mult, double tension, At&& at) {
  const int last = count - 1 - mult;
  double p0, p1, p2, p3, t;
  if (k < mult) {
    p0 = p1 = at(0);
    p2 = at(mult);
    p3 = at(2 * mult);
    t = k / static_cast<double>(mult);
  } else if (k > last) {
    p0 = at(last - mult);
    p1 = at(last);
    p2 = p3 = at(last + mult);
    t = (k - last) / static_cast<double>(mult);
  } else {
    const int i = (k / mult) * mult;
    p0 = at(i - mult);
    p1 = at(i);
    p2 = at(i + mult);
    p3 = at(i + 2 * mult);
    t = (k - i) / static_cast<double>(mult);
  }
  return cardinal(p0, p1, p2, p3, t, tension);
}

}  // namespace

void ZMesh::sample_lagrange(const Profile& p) {
  const MeshParams& m = p.params;
  std::vector<double> xpts(static_cast<std::size_t>(m.x_count)), ypts(static_cast<std::size_t>(m.y_count));
  for (int i = 0; i < m.x_count; ++i) xpts[static_cast<std::size_t>(i)] = x_.min + x_.dist * (i * x_mult_);
  for (int j = 0; j < m.y_count; ++j) ypts[static_cast<std::size_t>(j)] = y_.min + y_.dist * (j * y_mult_);
  const std::size_t nx = static_cast<std::size_t>(x_.count);
  for (int row = 0; row < y_.count; row += y_mult_) {
    double* r = &grid_[static_cast<std::size_t>(row) * nx];
    for (int k = 0; k < x_.count; ++k) {
      if (k % x_mult_ == 0) continue;
      r[k] = lagrange(xpts, x_.min + x_.dist * k,
                      [&](std::size_t i) { return r[i * static_cast<std::size_t>(x_mult_)]; });
    }
  }
  for (int col = 0; col < x_.count; ++col) {
    for (int k = 0; k < y_.count; ++k) {
      if (k % y_mult_ == 0) continue;
      grid_[static_cast<std::size_t>(k) * nx + col] =
          lagrange(ypts, y_.min + y_.dist * k, [&](std::size_t j) {
            return grid_[j * static_cast<std::size_t>(y_mult_) * nx + col];
          });
    }
  }
}

void ZMesh::sample_bicubic(const Profile& p) {
  const double c = p.params.tension;
  const std::size_t nx = static_cast<std::size_t>(x_.count);
  for (int row = 0; row < y_.count; row += y_mult_) {
    double* r = &grid_[static_cast<std::size_t>(row) * nx];
    for (int k = 0; k < x_.count; ++k) {
      if (k % x_mult_ == 0) continue;
      r[k] = spline_at(k, x_.count, x_mult_, c, [&](int i) { return r[i]; });
    }
  }
  for (int col = 0; col < x_.count; ++col) {
    for (int k = 0; k < y_.count; ++k) {
      if (k % y_mult_ == 0) continue;
      grid_[static_cast<std::size_t>(k) * nx + col] = spline_at(
          k, y_.count, y_mult_, c, [&](int j) { return grid_[static_cast<std::size_t>(j) * nx + col]; });
    }
  }
}

std::pair<double, double> ZMesh::z_range() const {
  const auto [lo, hi] = std::minmax_element(grid_.begin(), grid_.end());
  return {*lo, *hi};
}

double ZMesh::z_average_rounded() const {
  // Python sums row by row, then the row sums; round() rounds half to even.
  double total = 0.0;
  const std::size_t nx = static_cast<std::size_t>(x_.count);
  for (int j = 0; j < y_.count; ++j) {
    double row = 0.0;
    for (std::size_t i = 0; i < nx; ++i) row += grid_[static_cast<std::size_t>(j) * nx + i];
    total += row;
  }
  const double avg = total / static_cast<double>(grid_.size());
  return std::nearbyint(avg * 100.0) / 100.0;
}

}  // namespace amctl::bedmesh
