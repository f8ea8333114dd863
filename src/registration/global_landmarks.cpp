// Property landmarks for global registration: the labelled points of a downsampled cloud grouped
// by class into clusters (single linkage within landmark_cluster_distance). A smaller cousin of
// loop/landmarks.cpp (registration must not depend on loop): only centroids are needed here,
// since a constellation is matched by its distances alone.
#include <algorithm>
#include <numeric>

#include "global_internal.hpp"

namespace hazmap::global {

// Internal thresholds of global registration (issue 37: named constants, not keys; their old
// keys name this file). docs/registration.md, "Global registration".
/// m; same-class points closer than this are one landmark (a heat panel, a puddle).
constexpr double kLandmarkClusterDistance = 1.0;
/// Downsampled points a landmark needs: fewer is a stray label.
constexpr std::size_t kLandmarkMinPoints = 3;


std::vector<Landmark> clusterLandmarks(const LabeledCloud& cloud, const ClassTable& classes,
                                       std::vector<std::uint32_t>* members) {
  std::vector<std::uint32_t> labelled;
  for (std::uint32_t i = 0; i < cloud.size(); ++i)
    if (classes.isProperty(cloud.classes[i])) labelled.push_back(i);
  // Quadratic linkage: labelled points are a few hundred after downsampling; beyond this many
  // the cloud is mostly "property" and its clusters are no landmarks anyway.
  constexpr std::size_t kMaxLabelled = 4000;
  if (labelled.empty() || labelled.size() > kMaxLabelled) return {};
  std::vector<std::uint32_t> parent(labelled.size());
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const float r2 = static_cast<float>(kLandmarkClusterDistance * kLandmarkClusterDistance);
  for (std::uint32_t a = 0; a < labelled.size(); ++a)
    for (std::uint32_t b = a + 1; b < labelled.size(); ++b) {
      const auto i = labelled[a], j = labelled[b];
      if (cloud.classes[i] != cloud.classes[j]) continue;
      if ((cloud.points[i] - cloud.points[j]).squaredNorm() > r2) continue;
      const auto ra = find(a), rb = find(b);
      if (ra != rb) parent[std::max(ra, rb)] = std::min(ra, rb);
    }
  std::vector<Landmark> sums(labelled.size());
  for (std::uint32_t a = 0; a < labelled.size(); ++a) {
    Landmark& l = sums[find(a)];
    l.cls = cloud.classes[labelled[a]];
    l.centroid += cloud.points[labelled[a]];
    ++l.points;
  }
  if (members)
    for (std::uint32_t a = 0; a < labelled.size(); ++a)
      if (sums[find(a)].points >= kLandmarkMinPoints) members->push_back(labelled[a]);
  std::vector<Landmark> out;
  for (auto& l : sums) {
    if (l.points < kLandmarkMinPoints) continue;
    l.centroid /= static_cast<float>(l.points);
    out.push_back(l);
  }
  return out;
}

}  // namespace hazmap::global
