#pragma once
// Internal to the planner: Marlin's block buffer (Marlin/src/module/planner.cpp, read for
// behaviour). A ring of BLOCK_BUFFER_SIZE slots holds one block fewer, the executing one
// included: once that many blocks are queued the oldest one starts, planned as if the
// machine stopped after the newest; its exit speed fixes the next block's entry. A buffer
// size of 0 or 1 means unlimited look-ahead (up to the next full stop, bounded by
// max_queue). Also models SLOWDOWN (M205 B, min_segment_time) with the buffer fill of a
// file streamed faster than it prints. docs/planner.md, "Marlin and RepRapFirmware".
#include <cstddef>
#include <cstdint>

#include "move_queue.hpp"
#include "ramp_shape.hpp"
#include "timeline.hpp"

namespace amctl::plan::detail {

class MarlinBuffer {
 public:
  MarlinBuffer(RampShape ramps, Timeline& out, std::size_t buffer_size)
      : ramps_(ramps), out_(out), buffer_size_(buffer_size) {}

  /// Marlin's SLOWDOWN (SLOWDOWN_DIVISOR 2): the nominal speed of a block about to be queued
  /// whose segment (distance_mm at speed_mm_s) is shorter than min_segment_time_s while the
  /// buffer holds between 2 and BLOCK_BUFFER_SIZE/2 - 1 blocks. Buffer fill model: the k-th
  /// block after a full stop (k = 0, 1, 2, ...) finds k blocks queued; later blocks find the
  /// buffer full. Returns speed_mm_s when no slowdown applies.
  [[nodiscard]] double min_segment_time_speed(double distance_mm, double speed_mm_s,
                                              double min_segment_time_s) const {
    const std::uint64_t queued = blocks_since_stop_;
    if (queued < 2 || queued + 1 > buffer_size_ / 2) return speed_mm_s;
    const double segment_s = distance_mm / speed_mm_s;
    if (!(segment_s < min_segment_time_s)) return speed_mm_s;
    const double slowed_s = segment_s + 2.0 * (min_segment_time_s - segment_s) / static_cast<double>(queued);
    return distance_mm / slowed_s;
  }

  /// After a block was queued (its junction limit set): starts the oldest block once the
  /// ring is full. Returns true when an unlimited buffer reached max_queue (the caller notes
  /// the forced start and calls start_oldest()).
  [[nodiscard]] bool after_queued(MoveQueue& queue, std::size_t max_queue) {
    ++blocks_since_stop_;
    if (buffer_size_ > 1) {
      if (queue.size() >= buffer_size_ - 1) start_oldest(queue);
      return false;
    }
    return queue.size() >= max_queue;
  }

  /// Plans the buffer ending at rest and executes (emits) its oldest block.
  void start_oldest(MoveQueue& queue);

  /// Executes every queued block, ending at rest.
  void drain(MoveQueue& queue) {
    while (!queue.empty()) start_oldest(queue);
  }

  /// The machine is at rest with an empty buffer (after a synchronisation).
  void after_full_stop() { blocks_since_stop_ = 0; }

 private:
  template <class Shape>
  void start_oldest_with(MoveQueue& queue);

  RampShape ramps_;
  Timeline& out_;
  std::size_t buffer_size_ = 16;
  std::uint64_t blocks_since_stop_ = 0;
};

}  // namespace amctl::plan::detail
