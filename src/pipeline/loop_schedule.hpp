#pragma once
// When the back end searches a keyframe for loops (SlamConfig::loop_search_every,
// loop_pause_after_accept), and how often it solves the graph with the loops it accepted. A loop search is the online path's main cost — candidate
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

/// A solve of the whole graph costs about its node count (~45 µs a node on this machine's 2 cores,
/// docs/live.md), and a mission revisiting its route accepts a loop at nearly every keyframe:
/// solving at each, the back end's work per keyframe grew with the mission until it fell behind
/// (at ~30 minutes, 20,000 frames, on the closed route with icp+pgo). Beyond this many nodes the
/// loops accepted meanwhile are solved together once every ⌈nodes / it⌉ keyframes, so a
/// keyframe's share of the solving stays about constant; below, every accepted loop is solved at
/// once. By the graph's size, not the clock, so a replay solves where the recording's run did.
inline constexpr std::size_t kNodesSolvedPerKeyframe = 4000;

/// Keyframes from one solve with loops to the next, for a graph of `nodes` poses (>= 1).
inline std::size_t keyframesBetweenSolves(std::size_t nodes) {
  return nodes <= kNodesSolvedPerKeyframe ? 1 : (nodes + kNodesSolvedPerKeyframe - 1) / kNodesSolvedPerKeyframe;
}

}  // namespace hazmap
