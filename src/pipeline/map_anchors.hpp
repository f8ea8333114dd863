#pragma once
// Map-anchor edges (frame-to-map tracking, SlamConfig::anchor_radius): at each keyframe, an edge
// to the nearest keyframe within anchor_radius that is at least loop_closure.candidates.
// min_index_gap keyframes older. Frame-to-map tracking registered the keyframe against a map
// holding that keyframe's points, so their tracked relative pose is a measurement as good as one
// registration, not the random walk the chain of increments implies.
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "hazmap/graph/chain_covariance.hpp"
#include "hazmap/graph/pose_graph.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "pipeline/tracked_poses.hpp"

namespace hazmap::pipeline_detail {

class MapAnchors {
 public:
  explicit MapAnchors(const SlamConfig& config) : config_(config) {}

  /// The next frame's step: the share of its increment no registration vouched for (its whole
  /// edge covariance when it fell back; zero for the first frame).
  void addStep(const FrameRecord& rec, const Matrix6d& edge_covariance);
  /// The anchor edge of the newest keyframe (the newest frame, `newest` its record) into `graph`,
  /// if an older keyframe is near enough; returns its (from, to) frames.
  std::optional<std::pair<std::size_t, std::size_t>> anchorNewest(const std::vector<std::size_t>& keyframe_frames,
                                                                  const TrackedPoses& tracked,
                                                                  const FrameRecord& newest, PoseGraph& graph);
  /// The anchors' information with the shared drift counted once (before every optimisation).
  void refreshInformation(PoseGraph& graph) const;

 private:
  struct Anchor {
    std::size_t from, to;  // frames
    Matrix6d own;          // the keyframe's registration covariance + the anchor's own σ
    Matrix6d shared;       // the chained dead-reckoned steps it spans
  };
  const SlamConfig& config_;
  // Each frame's share no registration vouched for, where it is not zero (a tracked frame's is:
  // ~300 bytes a frame saved on a long mission, issue 33).
  SparseSteps guess_steps_;
  std::vector<Anchor> anchors_;
};

}  // namespace hazmap::pipeline_detail
