#pragma once
// Test helper: how close two maps' cells are (for maps built alike but not bit for bit, e.g. one
// re-placed from segments against one rebuilt from every scan).
#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "hazmap/map/global_map.hpp"

namespace hazmap::test {

/// For each cell of `a`, the distance (m) to the nearest centroid of `b` within `reach` cells on
/// every axis; `none` where `b` has no cell there.
inline std::vector<double> nearestCentroidDistances(const GlobalMap& a, const GlobalMap& b, int reach, double none) {
  const auto key = [](const Eigen::Vector3i& v) {
    return (std::int64_t(v.x()) << 42) ^ (std::int64_t(v.y()) << 21) ^ std::int64_t(v.z() & 0x1fffff);
  };
  std::unordered_map<std::int64_t, Eigen::Vector3f> centroids;
  for (const MapCell& d : b.cells()) centroids[key(d.index)] = d.centroid;
  std::vector<double> out;
  for (const MapCell& c : a.cells()) {
    double best = none;
    for (int dx = -reach; dx <= reach; ++dx)
      for (int dy = -reach; dy <= reach; ++dy)
        for (int dz = -reach; dz <= reach; ++dz)
          if (const auto it = centroids.find(key(c.index + Eigen::Vector3i(dx, dy, dz))); it != centroids.end())
            best = std::min(best, double((it->second - c.centroid).norm()));
    out.push_back(best);
  }
  return out;
}

}  // namespace hazmap::test
