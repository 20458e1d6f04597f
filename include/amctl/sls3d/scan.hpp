#pragma once
// The sintering laser's path over a layer's cross-section (docs/sls3d.md, section 3): parallel
// hatch vectors `hatch_m` apart, scanned at `speed_m_s`, in a serpentine (each vector in the
// opposite direction of the one before), with the jumps between vectors taken as instantaneous
// (galvanometer jumps are an order of magnitude faster than the marking speed). The scan time
// is then the cross-section's area / (hatch x speed) up to the staircase at its edges.
#include <vector>

#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d {

/// One hatch vector: from (x0, y0) to (x1, y1) during [t0_s, t1_s] after the exposure start.
struct ScanVector {
  double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
  double t0_s = 0, t1_s = 0;
};

struct HatchSettings {
  double hatch_m = 3e-4;
  double speed_m_s = 5.0;
  /// Direction of the vectors, radians from +x (the hatch advances along the normal).
  double angle_rad = 0.0;
};

/// A layer's scan: vectors in time order.
class ScanPath {
 public:
  ScanPath() = default;
  explicit ScanPath(std::vector<ScanVector> vectors);

  [[nodiscard]] const std::vector<ScanVector>& vectors() const { return vectors_; }
  [[nodiscard]] double duration_s() const { return vectors_.empty() ? 0.0 : vectors_.back().t1_s; }
  [[nodiscard]] double length_m() const { return length_m_; }
  /// The pieces of the path traversed during [a_s, b_s] (times after the exposure start),
  /// as passes at absolute times (+ offset_s) with the given absorbed power.
  [[nodiscard]] std::vector<LaserPass> passes(double a_s, double b_s, double offset_s,
                                              double power_w) const;
  /// Beam centre at time t_s after the exposure start (the last point after the end).
  [[nodiscard]] std::array<double, 2> position(double t_s) const;

 private:
  std::vector<ScanVector> vectors_;
  double length_m_ = 0.0;
};

/// Hatch of the ring inner_radius <= r <= outer_radius centred at the origin: hatch lines
/// through the ring at offsets (j + 1/2) h from its edge, each cut into its chords.
[[nodiscard]] ScanPath hatch_ring(double inner_radius_m, double outer_radius_m,
                                  const HatchSettings& s);

/// Hatch of the axis-aligned rectangle [x0, x1] x [y0, y1] (angle 0: vectors along x; pi/2:
/// along y; other angles are refused).
[[nodiscard]] ScanPath hatch_rectangle(double x0_m, double y0_m, double x1_m, double y1_m,
                                       const HatchSettings& s);

}  // namespace amctl::sls3d
