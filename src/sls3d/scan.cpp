// Hatch paths of the ring and of a rectangular patch (amctl/sls3d/scan.hpp).
#include "amctl/sls3d/scan.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "amctl/core/error.hpp"

namespace amctl::sls3d {

ScanPath::ScanPath(std::vector<ScanVector> vectors) : vectors_(std::move(vectors)) {
  for (const ScanVector& v : vectors_) length_m_ += std::hypot(v.x1_m - v.x0_m, v.y1_m - v.y0_m);
}

std::vector<LaserPass> ScanPath::passes(double a_s, double b_s, double offset_s,
                                        double power_w) const {
  std::vector<LaserPass> out;
  if (!(b_s > a_s)) return out;
  // First vector that ends after a.
  auto it = std::upper_bound(vectors_.begin(), vectors_.end(), a_s,
                             [](double t, const ScanVector& v) { return t < v.t1_s; });
  for (; it != vectors_.end() && it->t0_s < b_s; ++it) {
    const double t0 = std::max(a_s, it->t0_s), t1 = std::min(b_s, it->t1_s);
    if (!(t1 > t0)) continue;
    const double span = it->t1_s - it->t0_s;
    const double u0 = (t0 - it->t0_s) / span, u1 = (t1 - it->t0_s) / span;
    LaserPass p;
    p.x0_m = it->x0_m + u0 * (it->x1_m - it->x0_m);
    p.y0_m = it->y0_m + u0 * (it->y1_m - it->y0_m);
    p.x1_m = it->x0_m + u1 * (it->x1_m - it->x0_m);
    p.y1_m = it->y0_m + u1 * (it->y1_m - it->y0_m);
    p.t0_s = t0 + offset_s;
    p.t1_s = t1 + offset_s;
    p.power_w = power_w;
    out.push_back(p);
  }
  return out;
}

std::array<double, 2> ScanPath::position(double t_s) const {
  if (vectors_.empty()) return {0.0, 0.0};
  auto it = std::upper_bound(vectors_.begin(), vectors_.end(), t_s,
                             [](double t, const ScanVector& v) { return t < v.t1_s; });
  if (it == vectors_.end()) return {vectors_.back().x1_m, vectors_.back().y1_m};
  const double span = it->t1_s - it->t0_s;
  const double u = span > 0 ? std::clamp((t_s - it->t0_s) / span, 0.0, 1.0) : 0.0;
  return {it->x0_m + u * (it->x1_m - it->x0_m), it->y0_m + u * (it->y1_m - it->y0_m)};
}

namespace {

// Chords of the hatch lines in the frame (u along the vectors, w across), turned into the
// serpentine and rotated back by angle.
ScanPath serpentine(const std::vector<std::vector<std::pair<double, double>>>& chords_per_line,
                    const std::vector<double>& w_of_line, const HatchSettings& s) {
  const double c = std::cos(s.angle_rad), sn = std::sin(s.angle_rad);
  std::vector<ScanVector> out;
  double t = 0;
  bool forward = true;
  for (std::size_t j = 0; j < chords_per_line.size(); ++j) {
    auto chords = chords_per_line[j];
    if (chords.empty()) continue;
    if (!forward) {
      std::reverse(chords.begin(), chords.end());
      for (auto& ch : chords) std::swap(ch.first, ch.second);
    }
    const double w = w_of_line[j];
    for (const auto& [u0, u1] : chords) {
      ScanVector v;
      v.x0_m = u0 * c - w * sn;
      v.y0_m = u0 * sn + w * c;
      v.x1_m = u1 * c - w * sn;
      v.y1_m = u1 * sn + w * c;
      v.t0_s = t;
      t += std::abs(u1 - u0) / s.speed_m_s;
      v.t1_s = t;
      out.push_back(v);
    }
    forward = !forward;
  }
  return ScanPath(std::move(out));
}

}  // namespace

ScanPath hatch_ring(double inner_radius_m, double outer_radius_m, const HatchSettings& s) {
  AMCTL_CHECK(outer_radius_m > inner_radius_m && inner_radius_m >= 0 && s.hatch_m > 0 &&
                  s.speed_m_s > 0,
              "hatch_ring: validated settings");
  const double ro = outer_radius_m, ri = inner_radius_m;
  const int lines = int(std::floor(2.0 * ro / s.hatch_m));
  const double first = -0.5 * lines * s.hatch_m + 0.5 * s.hatch_m;  // centred on the ring
  std::vector<std::vector<std::pair<double, double>>> chords;
  std::vector<double> ws;
  for (int j = 0; j < lines; ++j) {
    const double w = first + j * s.hatch_m;
    if (std::abs(w) >= ro) continue;
    const double uo = std::sqrt(ro * ro - w * w);
    std::vector<std::pair<double, double>> line;
    if (std::abs(w) < ri) {
      const double ui = std::sqrt(ri * ri - w * w);
      line.push_back({-uo, -ui});
      line.push_back({ui, uo});
    } else {
      line.push_back({-uo, uo});
    }
    chords.push_back(line);
    ws.push_back(w);
  }
  return serpentine(chords, ws, s);
}

ScanPath hatch_rectangle(double x0_m, double y0_m, double x1_m, double y1_m,
                         const HatchSettings& s) {
  AMCTL_CHECK(x1_m > x0_m && y1_m > y0_m && s.hatch_m > 0 && s.speed_m_s > 0,
              "hatch_rectangle: validated settings");
  const bool along_x = std::abs(std::sin(s.angle_rad)) < 1e-12;
  const bool along_y = std::abs(std::cos(s.angle_rad)) < 1e-12;
  if (!along_x && !along_y)
    throw Error("hatch angle of a rectangle must be a multiple of 90 degrees, got " +
                std::to_string(s.angle_rad * 180.0 / std::numbers::pi));
  // In the rotated frame u runs along the vectors and w across them.
  HatchSettings hs = s;
  double u0, u1, w0, w1;
  if (along_x) {
    const bool flip = std::cos(s.angle_rad) < 0;
    hs.angle_rad = flip ? std::numbers::pi : 0.0;
    u0 = flip ? -x1_m : x0_m;
    u1 = flip ? -x0_m : x1_m;
    w0 = flip ? -y1_m : y0_m;
    w1 = flip ? -y0_m : y1_m;
  } else {
    const bool flip = std::sin(s.angle_rad) < 0;
    hs.angle_rad = flip ? -0.5 * std::numbers::pi : 0.5 * std::numbers::pi;
    // (x, y) = (-w, u) for +90 degrees, (w, -u) for -90 degrees.
    u0 = flip ? -y1_m : y0_m;
    u1 = flip ? -y0_m : y1_m;
    w0 = flip ? x0_m : -x1_m;
    w1 = flip ? x1_m : -x0_m;
  }
  const int lines = std::max(1, int(std::floor((w1 - w0) / s.hatch_m + 1e-9)));
  const double first = 0.5 * (w0 + w1) - 0.5 * (lines - 1) * s.hatch_m;
  std::vector<std::vector<std::pair<double, double>>> chords;
  std::vector<double> ws;
  for (int j = 0; j < lines; ++j) {
    chords.push_back({{u0, u1}});
    ws.push_back(first + j * s.hatch_m);
  }
  return serpentine(chords, ws, hs);
}

}  // namespace amctl::sls3d
