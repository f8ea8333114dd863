#include "hazmap/preprocess/voxel_downsample.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

// 21 bits per axis (±1M voxels) packed in 64 bits; sorting by this key groups each voxel's points.
std::uint64_t voxelKey(const Eigen::Vector3f& p, double inv) {
  const auto axis = [inv](float v) {
    const long long c = static_cast<long long>(std::floor(static_cast<double>(v) * inv)) + (1LL << 20);
    return static_cast<std::uint64_t>(std::clamp(c, 0LL, (1LL << 21) - 1));
  };
  return (axis(p.x()) << 42) | (axis(p.y()) << 21) | axis(p.z());
}

}  // namespace

LabeledCloud voxelDownsample(const LabeledCloud& cloud, const VoxelDownsampleConfig& config,
                             const ClassTable& table) {
  if (!(config.voxel_size > 0.0) || !std::isfinite(config.voxel_size))
    fail("voxel downsample", "voxel_size must be > 0 (got " + std::to_string(config.voxel_size) + ")");
  if (!(config.property_share >= 0.0 && config.property_share <= 1.0))
    fail("voxel downsample", "property_share must be in [0, 1]");
  const double inv = 1.0 / config.voxel_size;
  const std::size_t n = cloud.size();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  for (std::size_t i = 0; i < n; ++i) keyed[i] = {voxelKey(cloud.points[i], inv), std::uint32_t(i)};
  std::sort(keyed.begin(), keyed.end());

  LabeledCloud out = LabeledCloud::withLayoutOf(cloud);
  out.reserve(n / 4 + 1);
  std::vector<std::pair<ClassId, std::uint32_t>> votes;  // small: few classes per voxel
  for (std::size_t begin = 0; begin < n;) {
    std::size_t end = begin;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double si = 0, st = 0, sp = 0;
    votes.clear();
    while (end < n && keyed[end].first == keyed[begin].first) {
      const std::uint32_t i = keyed[end].second;
      sum += cloud.points[i].cast<double>();
      if (cloud.hasIntensity()) si += cloud.intensity[i];
      if (cloud.hasTimestamps()) st += cloud.timestamps[i];
      if (cloud.hasProperty()) sp += cloud.property[i];
      const ClassId c = cloud.classes[i];
      auto it = std::find_if(votes.begin(), votes.end(), [c](const auto& v) { return v.first == c; });
      if (it == votes.end()) votes.push_back({c, 1}); else ++it->second;
      ++end;
    }
    const double count = static_cast<double>(end - begin);
    std::sort(votes.begin(), votes.end(), [](const auto& a, const auto& b) {
      return a.second != b.second ? a.second > b.second : a.first < b.first;
    });
    ClassId cls = votes.front().first;
    if (config.vote == ClassVote::PreferProperty) {
      for (const auto& [c, k] : votes) {  // already ordered by count
        if (table.isProperty(c) && k >= config.property_share * count) { cls = c; break; }
      }
    }
    out.push_back((sum / count).cast<float>(), cls, static_cast<float>(si / count), st / count,
                  static_cast<float>(sp / count));
    begin = end;
  }
  return out;
}

}  // namespace hazmap
