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
  // Group points by voxel without sorting all points: an open-addressing table gives each voxel an
  // id, a counting sort groups the points (stable: original order inside a voxel), and only the
  // voxels are sorted by key — same output as sorting (key, index) pairs, several times faster.
  std::size_t table_size = 16;
  while (table_size < 2 * n) table_size <<= 1;
  const std::size_t mask = table_size - 1;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::vector<std::uint64_t> table_keys(table_size, kEmpty);
  std::vector<std::uint32_t> table_ids(table_size, 0);
  std::vector<std::uint64_t> voxel_keys;
  std::vector<std::uint32_t> point_voxel(n), counts;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = voxelKey(cloud.points[i], inv);
    std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
    std::size_t slot = (h ^ (h >> 29)) & mask;
    while (table_keys[slot] != kEmpty && table_keys[slot] != key) slot = (slot + 1) & mask;
    if (table_keys[slot] == kEmpty) {
      table_keys[slot] = key;
      table_ids[slot] = static_cast<std::uint32_t>(voxel_keys.size());
      voxel_keys.push_back(key);
      counts.push_back(0);
    }
    point_voxel[i] = table_ids[slot];
    ++counts[point_voxel[i]];
  }
  std::vector<std::uint32_t> start(voxel_keys.size() + 1, 0);
  for (std::size_t v = 0; v < voxel_keys.size(); ++v) start[v + 1] = start[v] + counts[v];
  std::vector<std::uint32_t> grouped(n);
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) grouped[fill[point_voxel[i]]++] = static_cast<std::uint32_t>(i);
  }
  std::vector<std::uint32_t> order(voxel_keys.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return voxel_keys[a] < voxel_keys[b]; });

  LabeledCloud out = LabeledCloud::withLayoutOf(cloud);
  out.reserve(n / 4 + 1);
  std::vector<std::pair<ClassId, std::uint32_t>> votes;  // small: few classes per voxel
  for (const std::uint32_t v : order) {
    const std::size_t begin = start[v], end = start[v + 1];
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double si = 0, st = 0, sp = 0;
    votes.clear();
    for (std::size_t k = begin; k < end; ++k) {
      const std::uint32_t i = grouped[k];
      sum += cloud.points[i].cast<double>();
      if (cloud.hasIntensity()) si += cloud.intensity[i];
      if (cloud.hasTimestamps()) st += cloud.timestamps[i];
      if (cloud.hasProperty()) sp += cloud.property[i];
      const ClassId c = cloud.classes[i];
      auto it = std::find_if(votes.begin(), votes.end(), [c](const auto& v) { return v.first == c; });
      if (it == votes.end()) votes.push_back({c, 1}); else ++it->second;
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
  }
  return out;
}

}  // namespace hazmap
