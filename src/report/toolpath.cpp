#include "amctl/report/toolpath.hpp"

#include <algorithm>
#include <cmath>

#include "amctl/core/error.hpp"

namespace amctl::report {
namespace {

constexpr int kMaxDoublings = 8;
constexpr std::int32_t kStart = -2;
constexpr std::int32_t kTravel = -1;

double dist_mm(const ToolpathVertex& a, const ToolpathVertex& b) {
  return std::hypot(static_cast<double>(a.x_mm) - b.x_mm, static_cast<double>(a.y_mm) - b.y_mm);
}

/// Folds the merged vertex `p` (which ends where the segment of `v` starts) into `v`.
void merge_into(const ToolpathVertex& p, ToolpathVertex& v) {
  v.speed_mm_s = std::max(v.speed_mm_s, p.speed_mm_s);
  v.error_mm = std::max(v.error_mm, p.error_mm);
  v.t0_s = p.t0_s;
}

}  // namespace

std::vector<ToolpathVertex> decimate(const std::vector<ToolpathVertex>& in, double tolerance_mm) {
  std::vector<ToolpathVertex> out;
  out.reserve(in.size());
  bool has_pending = false;
  ToolpathVertex pending{};
  for (ToolpathVertex v : in) {
    if (has_pending && (v.kind == kStart || pending.kind != v.kind)) {
      out.push_back(pending);
      has_pending = false;
    }
    if (out.empty() || v.kind == kStart) {
      out.push_back(v);
      continue;
    }
    if (has_pending) {
      merge_into(pending, v);
      has_pending = false;
    }
    if (dist_mm(v, out.back()) >= tolerance_mm) {
      out.push_back(v);
    } else {
      pending = v;
      has_pending = true;
    }
  }
  if (has_pending) out.push_back(pending);
  return out;
}

ToolpathSink::ToolpathSink(ToolpathOptions options) : options_(options) {
  require_positive("tolerance_mm", options_.tolerance_mm);
  if (options_.max_points_per_layer < 16 || options_.max_points < options_.max_points_per_layer) {
    throw Error("toolpath caps: max_points_per_layer >= 16 and max_points >= max_points_per_layer");
  }
  global_tolerance_mm_ = options_.tolerance_mm;
}

void ToolpathSink::redecimate(ToolpathLayer& layer) {
  const std::size_t before = layer.vertices.size();
  layer.vertices = decimate(layer.vertices, layer.tolerance_mm);
  total_points_ -= before - layer.vertices.size();
}

void ToolpathSink::fix_cursor() {
  // Vertices were merged: point the cursor at the first vertex not wholly before it.
  if (cursor_layer_ >= layers_.size()) return;
  const std::vector<ToolpathVertex>& vs = layers_[cursor_layer_].vertices;
  const double t = last_sample_t_s_;
  cursor_vertex_ = static_cast<std::size_t>(
      std::lower_bound(vs.begin(), vs.end(), t,
                       [](const ToolpathVertex& v, double ts) { return v.t1_s < ts; }) -
      vs.begin());
}

void ToolpathSink::commit(ToolpathVertex v) {
  ToolpathLayer& layer = layers_.back();
  if (layer.truncated) return;
  // Make room before adding, so that neither cap is ever exceeded.
  if (layer.vertices.size() >= options_.max_points_per_layer) {
    capped_ = true;
    for (int i = 0; i < kMaxDoublings && layer.vertices.size() > options_.max_points_per_layer / 2; ++i) {
      layer.tolerance_mm *= 2.0;
      redecimate(layer);
    }
    fix_cursor();
    if (layer.vertices.size() >= options_.max_points_per_layer) {
      layer.truncated = true;
      return;
    }
  }
  if (total_points_ >= options_.max_points) {
    capped_ = true;
    for (int i = 0; i < kMaxDoublings && total_points_ > options_.max_points * 3 / 4; ++i) {
      global_tolerance_mm_ *= 2.0;
      for (ToolpathLayer& l : layers_) {
        if (l.tolerance_mm < global_tolerance_mm_) {
          l.tolerance_mm = global_tolerance_mm_;
          redecimate(l);
        }
      }
    }
    fix_cursor();
    if (total_points_ >= options_.max_points) {
      for (ToolpathLayer& l : layers_) l.truncated = true;
      return;
    }
  }
  if (v.kind != kStart && carry_error_mm_ >= 0.0F) {
    v.error_mm = std::max(v.error_mm, carry_error_mm_);
    carry_error_mm_ = -1.0F;
  }
  layer.vertices.push_back(v);
  ++total_points_;
}

void ToolpathSink::flush_pending() {
  if (!has_pending_) return;
  has_pending_ = false;
  commit(pending_);
}

void ToolpathSink::push(ToolpathVertex v) {
  ToolpathLayer& layer = layers_.back();
  if (has_pending_ && pending_.kind != v.kind) flush_pending();
  if (has_pending_) {
    merge_into(pending_, v);
    has_pending_ = false;
  }
  if (layer.vertices.empty() || dist_mm(v, layer.vertices.back()) >= layer.tolerance_mm) {
    commit(v);
  } else {
    pending_ = v;
    has_pending_ = true;
  }
}

void ToolpathSink::add_move(const plan::PlannedMove& m) {
  if (m.extrude_only) return;
  const double dx = m.axes_r[0] * m.distance_mm;
  const double dy = m.axes_r[1] * m.distance_mm;
  if (dx == 0.0 && dy == 0.0) return;
  ++moves_;
  const bool extruding = m.is_extruding();
  if (layers_.empty() || layers_.back().layer != m.layer) {
    flush_pending();
    ToolpathLayer l;
    l.layer = m.layer;
    l.z_mm = m.start_mm[2];
    l.tolerance_mm = global_tolerance_mm_;
    if (!layers_.empty() && layers_.back().truncated && total_points_ >= options_.max_points) {
      l.truncated = true;
    }
    layers_.push_back(std::move(l));
  }
  ToolpathLayer& layer = layers_.back();
  ++layer.moves;
  if (extruding && layer.moves == 1) layer.z_mm = m.start_mm[2];
  ToolpathVertex start;
  start.x_mm = static_cast<float>(m.start_mm[0]);
  start.y_mm = static_cast<float>(m.start_mm[1]);
  start.t0_s = start.t1_s = m.start_time_s;
  start.kind = kStart;
  const ToolpathVertex* last = has_pending_ ? &pending_
                               : layer.vertices.empty() ? nullptr
                                                        : &layer.vertices.back();
  if (last == nullptr || std::abs(last->x_mm - start.x_mm) > 1e-3F ||
      std::abs(last->y_mm - start.y_mm) > 1e-3F) {
    flush_pending();
    commit(start);
  }
  ToolpathVertex v;
  v.x_mm = static_cast<float>(m.start_mm[0] + dx);
  v.y_mm = static_cast<float>(m.start_mm[1] + dy);
  v.speed_mm_s = static_cast<float>(std::max({m.start_v_mm_s, m.cruise_v_mm_s, m.end_v_mm_s}));
  v.t0_s = m.start_time_s;
  v.t1_s = m.end_time_s();
  v.kind = extruding ? static_cast<std::int32_t>(m.feature) : kTravel;
  push(v);
}

void ToolpathSink::consume(const plan::PlanBatch& batch) {
  for (const plan::PlannedMove& m : batch.moves) add_move(m);
}

void ToolpathSink::finish(const plan::StreamSummary& summary) {
  (void)summary;
  flush_pending();
  finished_ = true;
}

void ToolpathSink::add_error_sample(double t_s, double error_mm) {
  if (std::isnan(error_mm)) return;
  const auto e = static_cast<float>(error_mm);
  last_sample_t_s_ = t_s;
  // The segment a sample belongs to: the first vertex whose segment ends at or after t_s.
  // A sample between segments (a Z move, a retraction, a dwell, the settling after the last
  // move) goes to the segment that ended last: the nozzle is still there, ringing.
  auto previous_segment = [&]() -> ToolpathVertex* {
    std::size_t l = cursor_layer_, i = std::min(cursor_vertex_, layers_[l].vertices.size());
    while (true) {  // back over start vertices (at most one per polyline) to a segment
      if (i == 0) {
        if (l == 0) return nullptr;
        --l;
        i = layers_[l].vertices.size();
        continue;
      }
      --i;
      if (layers_[l].vertices[i].kind != kStart) return &layers_[l].vertices[i];
    }
  };
  while (cursor_layer_ < layers_.size()) {
    std::vector<ToolpathVertex>& vs = layers_[cursor_layer_].vertices;
    if (cursor_vertex_ >= vs.size()) {
      if (cursor_layer_ + 1 < layers_.size()) {
        ++cursor_layer_;
        cursor_vertex_ = 0;
        continue;
      }
      break;
    }
    ToolpathVertex& v = vs[cursor_vertex_];
    if (v.t1_s < t_s) {
      ++cursor_vertex_;
      continue;
    }
    if (v.kind != kStart && t_s >= v.t0_s) {
      v.error_mm = std::max(v.error_mm, e);
    } else if (ToolpathVertex* p = previous_segment()) {
      p->error_mm = std::max(p->error_mm, e);
    }
    return;
  }
  if (finished_ && !layers_.empty()) {
    cursor_layer_ = layers_.size() - 1;
    // After the last move: the settling of the nozzle at the end of the last segment.
    if (ToolpathVertex* p = previous_segment()) p->error_mm = std::max(p->error_mm, e);
    return;
  }
  // Past every committed vertex: the segment still pending.
  carry_error_mm_ = std::max(carry_error_mm_, e);
}

}  // namespace amctl::report
