// Re-anchoring frame-to-map tracking on a corrected trajectory (issue 14): after a pose-graph
// optimisation the local map and the frames' poses follow the graph, so tracking does not go on
// registering against a map that contradicts it.
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

void Odometry::reanchor(const std::vector<Eigen::Isometry3d>& poses) {
  if (poses.size() != frames_.size())
    fail("odometry reanchor", "needs one pose per frame (" + std::to_string(frames_.size()) + "), got " +
                                  std::to_string(poses.size()));
  for (const auto& p : poses)
    if (!isFinite(p)) fail("odometry reanchor", "a corrected pose has a non-finite entry");
  if (config_.mode != OdometryMode::FrameToMap || frames_.empty()) return;
  // One integrate() per frame (Odometry::remember), so the map's scan i is frame i.
  std::vector<Eigen::Isometry3d> corrections(frames_.size());
  for (std::size_t i = 0; i < frames_.size(); ++i) corrections[i] = normalized(poses[i] * frames_.pose(i).inverse());
  map_.reanchor(corrections, poses.back().translation(), classes_);
  ++impl_->reanchors;  // the whole-map target (keyframes at their poses) is stale
  for (std::size_t i = 0; i < frames_.size(); ++i) frames_.setPose(i, poses[i]);
}

}  // namespace hazmap
