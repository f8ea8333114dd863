#include "pipeline/map_anchors.hpp"

#include <algorithm>
#include <map>

#include "hazmap/graph/chain_covariance.hpp"
#include "pipeline/edge_noise.hpp"

namespace hazmap::pipeline_detail {

void MapAnchors::addStep(const FrameRecord& rec, const Matrix6d& edge_covariance) {
  if (rec.index == 0) return;
  const Matrix6d& step = rec.icp_used ? rec.guess_covariance : edge_covariance;
  if (!(step.array() == 0.0).all()) guess_steps_.emplace_back(rec.index, step);
}

// The shared part: the chained covariance of every increment's share that no registration
// vouched for (FrameRecord::guess_covariance: a fallback's whole covariance, a degenerate frame's
// along the directions where the guess was kept). There the tracker dead-reckoned, so its map
// places the newer keyframe relative to the older one no better than the chained guesses (tanks
// seed 8: anchors 25-42 cm and 20-38 mrad off, claiming 2-3 cm, turned the whole route 5 deg;
// docs/pose_graph.md).
std::optional<std::pair<std::size_t, std::size_t>> MapAnchors::anchorNewest(const std::vector<std::size_t>& keyframe_frames,
                                                                           const TrackedPoses& tracked,
                                                                           const FrameRecord& newest,
                                                                           PoseGraph& graph) {
  if (config_.odometry.mode != OdometryMode::FrameToMap || config_.anchor_radius <= 0.0) return std::nullopt;
  const std::size_t n = keyframe_frames.size(), gap = config_.loop_closure.candidates.min_index_gap;
  const std::size_t j = keyframe_frames.back();
  const Eigen::Isometry3d T_world_j = tracked.at(j);
  std::optional<std::size_t> best;
  double best_d = config_.anchor_radius;
  for (std::size_t k = 0; k + gap < n; ++k) {
    const double d = (tracked.at(keyframe_frames[k]).translation() - T_world_j.translation()).norm();
    if (d <= best_d) best_d = d, best = keyframe_frames[k];
  }
  if (!best) return std::nullopt;
  Matrix6d own = registrationEdgeCovariance(newest, config_);
  const double t = config_.anchor_sigma_translation, r = config_.anchor_sigma_rotation;
  own.diagonal() += translationRotationDiagonal(t * t, r * r);
  const Anchor a{*best, j, own, chainCovariance(graph.poses, guess_steps_, *best, j)};
  anchors_.push_back(a);
  graph.addEdge(static_cast<int>(*best), static_cast<int>(j), normalized(tracked.at(*best).inverse() * T_world_j),
                inverseOf(a.own + a.shared), EdgeKind::MapAnchor);
  return std::pair{*best, j};
}

// The anchors' dead-reckoned parts are one error shared by every anchor whose span covers the
// same steps (the tracker's map placed the whole return path with the same drift), not
// independent ones: counted as independent, n anchors across one stretch claimed √n times what
// they knew (corridor seed 3: 20-odd anchors held the return 30-90 cm off along the axis against
// the loops). So each anchor's shared part is multiplied by the number of anchors whose spans
// overlap its own (itself included): together they then claim the drift once, as covariance
// intersection does for estimates of unknown correlation. Later anchors join the overlap, hence
// the refresh before every optimisation.
void MapAnchors::refreshInformation(PoseGraph& graph) const {
  if (anchors_.empty()) return;
  std::map<std::pair<int, int>, Matrix6d> information;
  for (const Anchor& a : anchors_) {
    const auto overlapping =
        std::count_if(anchors_.begin(), anchors_.end(), [&](const Anchor& b) { return b.from < a.to && a.from < b.to; });
    information[{static_cast<int>(a.from), static_cast<int>(a.to)}] = inverseOf(a.own + static_cast<double>(overlapping) * a.shared);
  }
  for (PoseGraphEdge& e : graph.edges)
    if (e.kind == EdgeKind::MapAnchor)
      if (const auto it = information.find({e.from, e.to}); it != information.end()) e.information = it->second;
}

}  // namespace hazmap::pipeline_detail
