#pragma once
// When the back end searches a keyframe for loops (SlamConfig::loop_search_every,
// loop_pause_after_accept). A loop search is the online path's main cost — candidate
// verification by ICP, basin probes, the reverse cross-check, one optimisation per accepted loop
// (docs/measurements.md) — and along a revisited stretch every keyframe closes a loop to its old
// neighbour, each adding little once one of them has tied the two passes together.
#include <cstddef>

namespace hazmap {

class LoopSchedule {
 public:
  /// every >= 1: search keyframes whose index is a multiple of it; pause: after a keyframe whose
  /// search accepted a loop, the next `pause` keyframes are not searched.
  LoopSchedule(std::size_t every, std::size_t pause) : every_(every == 0 ? 1 : every), pause_(pause) {}

  /// Whether keyframe k is searched (k increasing).
  bool searches(std::size_t k) {
    const bool yes = k >= resume_at_ && k % every_ == 0;
    skipped_ += !yes;
    return yes;
  }
  /// Keyframe k's search accepted a loop.
  void accepted(std::size_t k) { resume_at_ = k + pause_ + 1; }
  std::size_t skipped() const { return skipped_; }

 private:
  std::size_t every_, pause_;
  std::size_t resume_at_ = 0;
  std::size_t skipped_ = 0;
};

}  // namespace hazmap
