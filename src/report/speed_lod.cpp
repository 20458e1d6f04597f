#include "amctl/report/speed_lod.hpp"

#include <algorithm>
#include <cmath>

#include "amctl/core/error.hpp"
#include "amctl/plan/velocity_profile.hpp"

namespace amctl::report {

int SpeedBucket::dominant_feature() const {
  int best = -1;
  float best_t = -1.0F;
  for (const auto& [f, t] : feature_time_s) {
    if (t > best_t) {
      best_t = t;
      best = f;
    }
  }
  return best;
}

double speed_in_phase(const plan::PlannedMove& m, int phase, double t_s) {
  if (m.extrude_only) return 0.0;
  if (phase == 1) return m.cruise_v_mm_s;
  const double v0 = phase == 0 ? m.start_v_mm_s : m.cruise_v_mm_s;
  const double v1 = phase == 0 ? m.cruise_v_mm_s : m.end_v_mm_s;
  const double dur = phase == 0 ? m.accel_t_s : m.decel_t_s;
  if (dur <= 0.0 || t_s <= 0.0) return v0;
  if (t_s >= dur) return v1;
  if (m.profile == plan::VelocityProfile::trapezoid) return v0 + (v1 - v0) * (t_s / dur);
  const plan::Ramp r = plan::make_ramp(m.profile, v0, v1, m.accel_mm_s2, m.jerk_mm_s3);
  return plan::evaluate_ramp(r, t_s * r.duration_s / dur).v_mm_s;
}

SpeedLodSink::SpeedLodSink(std::size_t max_buckets, double initial_bucket_s)
    : max_buckets_(max_buckets), bucket_s_(initial_bucket_s) {
  if (max_buckets < 2 || max_buckets % 2 != 0) throw Error("max_buckets must be even and >= 2");
  require_positive("initial_bucket_s", initial_bucket_s);
}

void SpeedLodSink::grow_to(double t_s) {
  // Double the width until time t_s falls inside the last allowed bucket.
  while (t_s >= bucket_s_ * static_cast<double>(max_buckets_)) {
    std::vector<SpeedBucket> merged((buckets_.size() + 1) / 2);
    for (std::size_t k = 0; k < buckets_.size(); ++k) {
      SpeedBucket& d = merged[k / 2];
      const SpeedBucket& s = buckets_[k];
      if (s.empty()) continue;
      if (d.empty()) {
        d.min_speed_mm_s = s.min_speed_mm_s;
        d.max_speed_mm_s = s.max_speed_mm_s;
      } else {
        d.min_speed_mm_s = std::min(d.min_speed_mm_s, s.min_speed_mm_s);
        d.max_speed_mm_s = std::max(d.max_speed_mm_s, s.max_speed_mm_s);
      }
      d.covered_s += s.covered_s;
      d.distance_mm += s.distance_mm;
      for (const auto& [f, t] : s.feature_time_s) {
        auto it = std::find_if(d.feature_time_s.begin(), d.feature_time_s.end(),
                               [f = f](const auto& p) { return p.first == f; });
        if (it == d.feature_time_s.end()) {
          d.feature_time_s.emplace_back(f, t);
        } else {
          it->second += t;
        }
      }
    }
    buckets_ = std::move(merged);
    bucket_s_ *= 2.0;
  }
  const auto need = static_cast<std::size_t>(std::floor(t_s / bucket_s_)) + 1;
  if (buckets_.size() < need) buckets_.resize(std::min(need, max_buckets_));
}

void SpeedLodSink::touch(std::size_t k, float vmin, float vmax, double dt_s, double distance_mm,
                         std::uint16_t feature) {
  SpeedBucket& b = buckets_[k];
  b.distance_mm += distance_mm;
  if (b.empty()) {
    b.min_speed_mm_s = vmin;
    b.max_speed_mm_s = vmax;
  } else {
    b.min_speed_mm_s = std::min(b.min_speed_mm_s, vmin);
    b.max_speed_mm_s = std::max(b.max_speed_mm_s, vmax);
  }
  // A zero-length touch (a move of no duration) still records its speed; covered time
  // is what marks the bucket as holding moves.
  b.covered_s += std::max(dt_s, 1e-12);
  for (auto& p : b.feature_time_s) {
    if (p.first == feature) {
      p.second += static_cast<float>(dt_s);
      return;
    }
  }
  b.feature_time_s.emplace_back(feature, static_cast<float>(dt_s));
}

void SpeedLodSink::add_span(double t0_s, double t1_s, double v0_mm_s, double v1_mm_s,
                            std::uint16_t feature, const plan::PlannedMove& m, int phase) {
  // One monotone phase [t0, t1] with speeds v0 -> v1, spread over the buckets it touches.
  grow_to(t1_s);
  const double w = bucket_s_;
  auto k = static_cast<std::size_t>(std::floor(t0_s / w));
  const auto k_end = std::min(static_cast<std::size_t>(std::floor(t1_s / w)), buckets_.size() - 1);
  k = std::min(k, k_end);
  if (k == k_end) {
    touch(k, static_cast<float>(std::min(v0_mm_s, v1_mm_s)), static_cast<float>(std::max(v0_mm_s, v1_mm_s)),
          t1_s - t0_s, 0.5 * (v0_mm_s + v1_mm_s) * (t1_s - t0_s), feature);
    return;
  }
  const double phase_start_s = t0_s;
  double a_s = t0_s;
  double va = v0_mm_s;
  for (; k <= k_end; ++k) {
    const double b_s = std::min(t1_s, static_cast<double>(k + 1) * w);
    const double vb = k == k_end ? v1_mm_s : speed_in_phase(m, phase, b_s - phase_start_s);
    touch(k, static_cast<float>(std::min(va, vb)), static_cast<float>(std::max(va, vb)), b_s - a_s,
          0.5 * (va + vb) * (b_s - a_s), feature);
    a_s = b_s;
    va = vb;
  }
}

void SpeedLodSink::add_move(const plan::PlannedMove& m) {
  const double t = m.start_time_s;
  if (m.extrude_only) {
    add_span(t, m.end_time_s(), 0.0, 0.0, m.feature, m, 1);
    return;
  }
  const double t1 = t + m.accel_t_s;
  const double t2 = t1 + m.cruise_t_s;
  const double t3 = t2 + m.decel_t_s;
  if (m.accel_t_s > 0.0) add_span(t, t1, m.start_v_mm_s, m.cruise_v_mm_s, m.feature, m, 0);
  if (m.cruise_t_s > 0.0) add_span(t1, t2, m.cruise_v_mm_s, m.cruise_v_mm_s, m.feature, m, 1);
  if (m.decel_t_s > 0.0) add_span(t2, t3, m.cruise_v_mm_s, m.end_v_mm_s, m.feature, m, 2);
  if (m.duration_s() <= 0.0) add_span(t, t, m.start_v_mm_s, m.end_v_mm_s, m.feature, m, 1);
}

void SpeedLodSink::consume(const plan::PlanBatch& batch) {
  for (const plan::PlannedMove& m : batch.moves) add_move(m);
}

void SpeedLodSink::finish(const plan::StreamSummary& summary) {
  end_time_s_ = summary.end_time_s;
  if (end_time_s_ > 0.0) grow_to(std::nextafter(end_time_s_, 0.0));
  // A bucket not wholly covered by moves stood still for part of its time.
  for (std::size_t k = 0; k < buckets_.size(); ++k) {
    SpeedBucket& b = buckets_[k];
    const double span_s = std::min(bucket_s_, end_time_s_ - static_cast<double>(k) * bucket_s_);
    if (b.empty()) {
      b.min_speed_mm_s = b.max_speed_mm_s = 0.0F;
    } else if (b.covered_s < span_s * (1.0 - 1e-6)) {
      b.min_speed_mm_s = 0.0F;
    }
  }
}

}  // namespace amctl::report
