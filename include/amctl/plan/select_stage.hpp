#pragma once
// A stage of the plan stream that keeps only the moves (and events) of a print-time or layer
// range, e.g. `amctl plan --layer-begin 10 --layer-end 12`. The moves are not re-timed: a
// move keeps its start time in the whole print, so a window can be compared with the rest.
#include <cstdint>
#include <limits>

#include "amctl/plan/stream.hpp"

namespace amctl::plan {

struct SelectOptions {
  /// Moves that overlap [t_begin_s, t_end_s] are kept; events inside it.
  double t_begin_s = -std::numeric_limits<double>::infinity();
  double t_end_s = std::numeric_limits<double>::infinity();
  /// Moves whose layer is in [layer_begin, layer_end] (PlannedMove::layer, -1 before the
  /// first layer annotation).
  std::int32_t layer_begin = std::numeric_limits<std::int32_t>::min();
  std::int32_t layer_end = std::numeric_limits<std::int32_t>::max();
};

class SelectStage final : public Stage {
 public:
  /// Throws amctl::Error for an empty or NaN range.
  explicit SelectStage(const SelectOptions& options);
  void process(PlanBatch& batch) override;
  [[nodiscard]] std::uint64_t kept_moves() const { return kept_; }
  [[nodiscard]] std::uint64_t dropped_moves() const { return dropped_; }

 private:
  [[nodiscard]] bool keep(const PlannedMove& m) const {
    return m.layer >= opt_.layer_begin && m.layer <= opt_.layer_end &&
           m.end_time_s() >= opt_.t_begin_s && m.start_time_s <= opt_.t_end_s;
  }
  SelectOptions opt_;
  std::int32_t layer_ = -1;  // layer in force (from layer events), for selecting events
  std::uint64_t kept_ = 0, dropped_ = 0;
};

}  // namespace amctl::plan
