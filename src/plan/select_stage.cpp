#include "amctl/plan/select_stage.hpp"

#include <cmath>
#include <utility>

#include <fmt/format.h>

#include "amctl/core/error.hpp"

namespace amctl::plan {

SelectStage::SelectStage(const SelectOptions& o) : opt_(o) {
  if (std::isnan(o.t_begin_s) || std::isnan(o.t_end_s) || o.t_end_s < o.t_begin_s) {
    throw Error(fmt::format("empty time range: end {} s is before begin {} s", o.t_end_s, o.t_begin_s));
  }
  if (o.layer_end < o.layer_begin) {
    throw Error(fmt::format("empty layer range: end {} is before begin {}", o.layer_end, o.layer_begin));
  }
}

void SelectStage::process(PlanBatch& batch) {
  // Compacts moves and events in place, renumbering each event's before_move.
  std::size_t out_moves = 0, out_events = 0, m = 0;
  auto take_moves_until = [&](std::size_t end) {
    for (; m < end; ++m) {
      if (keep(batch.moves[m])) {
        if (out_moves != m) batch.moves[out_moves] = batch.moves[m];
        ++out_moves;
        ++kept_;
      } else {
        ++dropped_;
      }
    }
  };
  for (std::size_t e = 0; e < batch.events.size(); ++e) {
    take_moves_until(batch.events[e].before_move);
    PlanEvent& ev = batch.events[e];
    if (ev.kind == PlanEvent::Kind::layer) layer_ = ev.layer;
    const std::int32_t layer = layer_;
    const bool inside = layer >= opt_.layer_begin && layer <= opt_.layer_end &&
                        ev.time_s >= opt_.t_begin_s && ev.time_s <= opt_.t_end_s;
    if (!inside) continue;
    ev.before_move = out_moves;
    if (out_events != e) batch.events[out_events] = std::move(ev);
    ++out_events;
  }
  take_moves_until(batch.moves.size());
  batch.moves.resize(out_moves);
  batch.events.resize(out_events);
}

}  // namespace amctl::plan
