#include "amctl/plan/velocity_profile.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::plan {
namespace {

void check_inputs(VelocityProfile profile, double v0, double v1, double accel, double jerk) {
  require_non_negative("start speed v0_mm_s", v0);
  require_non_negative("end speed v1_mm_s", v1);
  require_positive("accel_mm_s2", accel);
  if (profile == VelocityProfile::scurve7) require_positive("jerk_mm_s3 (scurve7)", jerk);
}

// scurve7 duration for a speed change dv >= 0.
double scurve_duration(double dv, double a, double j) {
  if (dv <= 0.0) return 0.0;
  if (dv >= a * a / j) return dv / a + a / j;
  return 2.0 * std::sqrt(dv / j);
}

PathState eval_piece(const PathPiece& p, double tau) {
  // Horner with derivatives: d0 = P, d1 = P', d2 = P''/2, d3 = P'''/6.
  double d0 = 0, d1 = 0, d2 = 0, d3 = 0;
  for (int k = p.degree; k >= 0; --k) {
    d3 = d3 * tau + d2;
    d2 = d2 * tau + d1;
    d1 = d1 * tau + d0;
    d0 = d0 * tau + p.c[static_cast<std::size_t>(k)];
  }
  return PathState{d0, d1, 2.0 * d2, 6.0 * d3};
}

}  // namespace

double ramp_duration_s(VelocityProfile profile, double v0, double v1, double accel,
                       double jerk) {
  check_inputs(profile, v0, v1, accel, jerk);
  const double dv = std::abs(v1 - v0);
  if (profile == VelocityProfile::scurve7) return scurve_duration(dv, accel, jerk);
  return dv / accel;
}

double ramp_distance_mm(VelocityProfile profile, double v0, double v1, double accel,
                        double jerk) {
  // Every shape here is point-symmetric about the middle of the ramp, so the mean speed
  // is (v0 + v1) / 2.
  return 0.5 * (v0 + v1) * ramp_duration_s(profile, v0, v1, accel, jerk);
}

double max_reachable_speed_mm_s(VelocityProfile profile, double v0, double distance,
                                double accel, double jerk) {
  check_inputs(profile, v0, v0, accel, jerk);
  require_non_negative("distance_mm", distance);
  if (profile != VelocityProfile::scurve7) return std::sqrt(v0 * v0 + 2.0 * accel * distance);
  const double a = accel, j = jerk;
  const double dv_th = a * a / j;           // smallest dv that reaches the accel limit
  const double d_th = (v0 + 0.5 * dv_th) * (2.0 * a / j);
  double dv = 0.0;
  if (distance >= d_th) {
    // (2 v0 + dv)(dv + a^2/j) = 2 a D  ->  dv^2 + b dv + c = 0
    const double b = 2.0 * v0 + dv_th;
    const double c = 2.0 * v0 * dv_th - 2.0 * a * distance;
    const double disc = b * b - 4.0 * c;
    dv = (-b + std::sqrt(std::max(disc, 0.0))) / 2.0;
    // Stable form when c ~ 0: dv = -2c / (b + sqrt(disc)).
    if (b > 0.0) dv = -2.0 * c / (b + std::sqrt(std::max(disc, 0.0)));
  } else {
    // (2 v0 + dv) sqrt(dv / j) = D; with s = sqrt(dv): s^3 + 2 v0 s - D sqrt(j) = 0 (Cardano,
    // one real root since the cubic is increasing), then two Newton polishes.
    const double p = 2.0 * v0, q = -distance * std::sqrt(j);
    const double disc = q * q / 4.0 + p * p * p / 27.0;
    const double r = std::sqrt(disc);
    double s = std::cbrt(-q / 2.0 + r) + std::cbrt(-q / 2.0 - r);
    for (int it = 0; it < 3; ++it) {
      const double f = s * s * s + p * s + q, df = 3.0 * s * s + p;
      if (df > 0.0) s -= f / df;
    }
    dv = std::max(s, 0.0) * std::max(s, 0.0);
  }
  return v0 + std::max(dv, 0.0);
}

namespace {

// scurve7 ramp distance from v0 to v (v >= v0) and its derivative in v.
struct DistSlope { double d; double dd; };
DistSlope scurve_ramp_dist(double v0, double v, double a, double j) {
  const double dv = v - v0;
  if (dv <= 0.0) return {0.0, 0.0};
  if (dv >= a * a / j) {
    // d = (v0 + v)/2 (dv/a + a/j)  ->  d' = (dv/a + a/j)/2 + (v0 + v)/(2a) = v/a + a/(2j)
    return {0.5 * (v0 + v) * (dv / a + a / j), v / a + 0.5 * a / j};
  }
  // d = (v0 + v) sqrt(dv/j)  ->  d' = sqrt(dv/j) + (v0 + v) / (2 sqrt(dv j))
  const double r = std::sqrt(dv / j);
  return {(v0 + v) * r, r + (v0 + v) / (2.0 * std::sqrt(dv * j))};
}

}  // namespace

double peak_speed_mm_s(VelocityProfile profile, double v0, double v1, double distance,
                       double accel, double jerk, double max_v) {
  const double lo0 = std::max(v0, v1);
  if (profile != VelocityProfile::scurve7) {
    const double vp = std::sqrt(0.5 * (v0 * v0 + v1 * v1) + accel * distance);
    return std::max(std::min(vp, max_v), lo0);
  }
  const double a = accel, j = jerk;
  // The S-curve needs more distance than the trapezoid for the same speeds, so the
  // trapezoid's peak bounds the root from above (and keeps an infinite cap finite).
  max_v = std::min(max_v, std::sqrt(0.5 * (v0 * v0 + v1 * v1) + a * distance));
  auto needed = [&](double v) {
    const DistSlope p = scurve_ramp_dist(v0, v, a, j), q = scurve_ramp_dist(v1, v, a, j);
    return DistSlope{p.d + q.d, p.dd + q.dd};
  };
  if (!(max_v > lo0)) return lo0;
  if (needed(max_v).d <= distance) return max_v;
  if (needed(lo0).d >= distance) return lo0;
  // Both ramps at the accel limit: (v^2 - v0^2)/2a + (v^2 - v1^2)/2a + a/2j (v0 + v1 + 2v) = D,
  // i.e. v^2/a + (a/j) v + c = 0; valid when v - max(v0, v1) >= a^2/j.
  const double c = -(v0 * v0 + v1 * v1) / (2.0 * a) + a * (v0 + v1) / (2.0 * j) - distance;
  const double b = a / j;
  const double disc = b * b - 4.0 * c / a;
  if (disc >= 0.0) {
    const double root = 0.5 * a * (-b + std::sqrt(disc));
    if (root - lo0 >= a * a / j && root <= max_v) return root;
  }
  // Bracketed Newton on f(v) = needed(v) - D, f(lo) < 0 < f(hi).
  double lo = lo0, hi = max_v;
  double v = std::min(hi, std::sqrt(0.5 * (v0 * v0 + v1 * v1) + a * distance));  // >= root
  for (int it = 0; it < 100; ++it) {
    const DistSlope f = needed(v);
    const double g = f.d - distance;
    if (g > 0.0) hi = v; else lo = v;
    if (g == 0.0 || hi - lo <= 1e-14 * hi) break;
    double next = (f.dd > 0.0 && std::isfinite(f.dd)) ? v - g / f.dd : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - v) <= 1e-14 * v) {
      v = next;
      break;
    }
    v = next;
  }
  // Newton from the right of a convex stretch ends a few ulps past the root: accept that
  // (1e-12 of the distance); otherwise fall back to the feasible end of the bracket.
  return needed(v).d - distance <= 1e-12 * distance ? v : lo;
}

Ramp make_ramp(VelocityProfile profile, double v0, double v1, double accel, double jerk) {
  check_inputs(profile, v0, v1, accel, jerk);
  Ramp r;
  r.profile = profile;
  r.v0_mm_s = v0;
  r.v1_mm_s = v1;
  r.accel_mm_s2 = accel;
  r.jerk_mm_s3 = profile == VelocityProfile::scurve7 ? jerk : 0.0;
  const double dv = std::abs(v1 - v0);
  switch (profile) {
    case VelocityProfile::trapezoid:
      r.duration_s = dv / accel;
      r.peak_accel_mm_s2 = dv > 0 ? accel : 0.0;
      break;
    case VelocityProfile::bezier5:
      r.duration_s = dv / accel;
      r.peak_accel_mm_s2 = dv > 0 ? 1.875 * accel : 0.0;
      r.peak_jerk_mm_s3 = dv > 0 ? (10.0 / std::sqrt(3.0)) * accel * accel / dv : 0.0;
      break;
    case VelocityProfile::scurve7:
      if (dv > 0.0) {
        if (dv >= accel * accel / jerk) {
          r.jerk_phase_t_s = accel / jerk;
          r.const_accel_t_s = dv / accel - accel / jerk;
          r.peak_accel_mm_s2 = accel;
        } else {
          r.jerk_phase_t_s = std::sqrt(dv / jerk);
          r.peak_accel_mm_s2 = jerk * r.jerk_phase_t_s;
        }
        r.duration_s = 2.0 * r.jerk_phase_t_s + r.const_accel_t_s;
        r.peak_jerk_mm_s3 = jerk;
      }
      break;
  }
  r.distance_mm = 0.5 * (v0 + v1) * r.duration_s;
  return r;
}

std::size_t ramp_pieces(const Ramp& r, double s0, std::array<PathPiece, 3>& out) {
  if (r.duration_s <= 0.0) return 0;
  const double dv = r.v1_mm_s - r.v0_mm_s;
  const double sg = dv >= 0 ? 1.0 : -1.0;
  const double v0 = r.v0_mm_s;
  switch (r.profile) {
    case VelocityProfile::trapezoid: {
      PathPiece p;
      p.duration_s = r.duration_s;
      p.degree = 2;
      p.c[0] = s0;
      p.c[1] = v0;
      p.c[2] = 0.5 * sg * r.accel_mm_s2;
      out[0] = p;
      return 1;
    }
    case VelocityProfile::bezier5: {
      // s = s0 + v0 t + dv T (5/2 u^4 - 3 u^5 + u^6), u = t / T.
      const double T = r.duration_s;
      PathPiece p;
      p.duration_s = T;
      p.degree = 6;
      p.c[0] = s0;
      p.c[1] = v0;
      p.c[4] = 2.5 * dv / (T * T * T);
      p.c[5] = -3.0 * dv / (T * T * T * T);
      p.c[6] = dv / (T * T * T * T * T);
      out[0] = p;
      return 1;
    }
    case VelocityProfile::scurve7: {
      const double j = r.jerk_mm_s3, tj = r.jerk_phase_t_s, ta = r.const_accel_t_s;
      const double ap = r.peak_accel_mm_s2;
      std::size_t n = 0;
      // Phase 1: jerk +sg j from zero accel.
      PathPiece p1;
      p1.duration_s = tj;
      p1.degree = 3;
      p1.c[0] = s0;
      p1.c[1] = v0;
      p1.c[3] = sg * j / 6.0;
      out[n++] = p1;
      double s = s0 + v0 * tj + sg * j * tj * tj * tj / 6.0;
      double v = v0 + sg * j * tj * tj / 2.0;
      if (ta > 0.0) {
        PathPiece p2;
        p2.duration_s = ta;
        p2.degree = 2;
        p2.c[0] = s;
        p2.c[1] = v;
        p2.c[2] = 0.5 * sg * ap;
        out[n++] = p2;
        s += v * ta + 0.5 * sg * ap * ta * ta;
        v += sg * ap * ta;
      }
      PathPiece p3;
      p3.duration_s = tj;
      p3.degree = 3;
      p3.c[0] = s;
      p3.c[1] = v;
      p3.c[2] = 0.5 * sg * ap;
      p3.c[3] = -sg * j / 6.0;
      out[n++] = p3;
      return n;
    }
  }
  return 0;
}

PathState evaluate_ramp(const Ramp& r, double t) {
  std::array<PathPiece, 3> pieces;
  const std::size_t n = ramp_pieces(r, 0.0, pieces);
  if (n == 0) return PathState{0.0, r.v0_mm_s, 0.0, 0.0};
  t = std::clamp(t, 0.0, r.duration_s);
  for (std::size_t i = 0; i < n; ++i) {
    if (t <= pieces[i].duration_s || i + 1 == n) {
      return eval_piece(pieces[i], std::min(t, pieces[i].duration_s));
    }
    t -= pieces[i].duration_s;
  }
  return PathState{};
}

MoveTiming time_move(VelocityProfile profile, double distance, double v_start, double v_max,
                     double v_end, double accel, double jerk) {
  require_positive("distance_mm", distance);
  require_positive("max_v_mm_s", v_max);
  check_inputs(profile, v_start, v_end, accel, jerk);
  if (v_start > v_max * (1 + 1e-12)) {
    throw Error(fmt::format("start_v_mm_s {} exceeds max_v_mm_s {}", v_start, v_max));
  }
  if (v_end > v_max * (1 + 1e-12)) {
    throw Error(fmt::format("end_v_mm_s {} exceeds max_v_mm_s {}", v_end, v_max));
  }
  auto needed = [&](double vc) {
    return ramp_distance_mm(profile, v_start, vc, accel, jerk) +
           ramp_distance_mm(profile, vc, v_end, accel, jerk);
  };
  const double lo0 = std::max(v_start, v_end);
  if (needed(lo0) > distance * (1.0 + 1e-9) + 1e-12) {
    throw Error(fmt::format(
        "end speeds {} -> {} mm/s cannot be joined within distance_mm {} (needs {} mm)", v_start,
        v_end, distance, needed(lo0)));
  }
  double vc = v_max;
  if (needed(v_max) > distance) {
    if (profile == VelocityProfile::scurve7) {
      double lo = lo0, hi = v_max;
      for (int it = 0; it < 200 && hi - lo > 1e-13 * hi; ++it) {
        const double mid = 0.5 * (lo + hi);
        (needed(mid) <= distance ? lo : hi) = mid;
      }
      vc = lo;
    } else {
      // (3.1): v_p = sqrt((v0^2 + v1^2)/2 + a D); same distances for bezier5.
      vc = std::sqrt(0.5 * (v_start * v_start + v_end * v_end) + accel * distance);
      vc = std::clamp(vc, lo0, v_max);
    }
  }
  MoveTiming m;
  m.start_v_mm_s = v_start;
  m.cruise_v_mm_s = vc;
  m.end_v_mm_s = v_end;
  m.accel = make_ramp(profile, v_start, vc, accel, jerk);
  m.decel = make_ramp(profile, vc, v_end, accel, jerk);
  m.accel_t_s = m.accel.duration_s;
  m.decel_t_s = m.decel.duration_s;
  const double cruise_d = std::max(0.0, distance - m.accel.distance_mm - m.decel.distance_mm);
  m.cruise_t_s = vc > 0.0 ? cruise_d / vc : 0.0;
  return m;
}

std::size_t move_pieces(const MoveTiming& m, std::array<PathPiece, 7>& out) {
  std::size_t n = 0;
  std::array<PathPiece, 3> tmp;
  const std::size_t na = ramp_pieces(m.accel, 0.0, tmp);
  for (std::size_t i = 0; i < na; ++i) out[n++] = tmp[i];
  double s = m.accel.distance_mm;
  if (m.cruise_t_s > 0.0) {
    PathPiece c;
    c.duration_s = m.cruise_t_s;
    c.degree = 1;
    c.c[0] = s;
    c.c[1] = m.cruise_v_mm_s;
    out[n++] = c;
    s += m.cruise_v_mm_s * m.cruise_t_s;
  }
  const std::size_t nd = ramp_pieces(m.decel, s, tmp);
  for (std::size_t i = 0; i < nd; ++i) out[n++] = tmp[i];
  return n;
}

}  // namespace amctl::plan
