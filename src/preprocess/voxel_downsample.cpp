#include "hazmap/preprocess/voxel_downsample.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/core/hash.hpp"
#include "hazmap/core/voxel_key.hpp"

namespace hazmap {

namespace {

constexpr std::uint64_t kSkip = ~std::uint64_t{0};  // point dropped (crop, non-finite, out of key range)

// Sorting by the voxel key (core/voxel_key.hpp, x-major) groups each voxel's points. kSkip for a
// point beyond the key's range (±2^20 voxels).
std::uint64_t voxelKeyOf(const Eigen::Vector3f& p, double inv) {
  std::array<std::int64_t, 3> c;
  std::uint64_t key = kSkip;
  voxelOfPoint(static_cast<double>(p.x()) * inv, static_cast<double>(p.y()) * inv, static_cast<double>(p.z()) * inv,
               c, key);
  return key;
}

void checkConfig(const VoxelDownsampleConfig& config) {
  if (!(config.voxel_size > 0.0) || !std::isfinite(config.voxel_size))
    fail("voxel downsample", "voxel_size must be > 0 (got " + std::to_string(config.voxel_size) + ")");
  if (!(config.property_share >= 0.0 && config.property_share <= 1.0))
    fail("voxel downsample", "property_share must be in [0, 1]");
}

// Each point's voxel key (kSkip: non-finite, cropped, or out of the key's range), in parallel.
// `crop` = keep only lo2 <= |p|² <= hi2.
std::vector<std::uint64_t> pointKeys(const LabeledCloud& cloud, double voxel_size, bool crop, double lo2, double hi2) {
  const double inv = 1.0 / voxel_size;
  const std::size_t n = cloud.size();
  std::vector<std::uint64_t> keys(n);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const Eigen::Vector3f& p = cloud.points[i];
      if (!p.allFinite()) {  // no voxel (and a NaN must not reach the integer conversion)
        keys[i] = kSkip;
        continue;
      }
      if (crop) {
        const double r2 = p.cast<double>().squaredNorm();
        if (!(std::isfinite(r2) && r2 >= lo2 && r2 <= hi2)) {
          keys[i] = kSkip;
          continue;
        }
      }
      keys[i] = voxelKeyOf(p, inv);
    }
  });
  return keys;
}

// The points grouped by voxel: voxel v (in key order) holds grouped[start[order[v]] …].
struct VoxelGroups {
  std::vector<std::uint32_t> start, grouped, order;
};

VoxelGroups groupByVoxel(const std::vector<std::uint64_t>& keys) {
  const std::size_t n = keys.size();
  // Group points by voxel without sorting all points: an open-addressing table gives each voxel an
  // id, a counting sort groups the points (stable: original order inside a voxel), and only the
  // voxels are sorted by key — same output as sorting (key, index) pairs (docs/measurements.md).
  std::size_t table_size = 16;
  while (table_size < 2 * n) table_size <<= 1;
  const std::size_t mask = table_size - 1;
  constexpr std::uint64_t kEmpty = ~std::uint64_t{0};
  std::vector<std::uint64_t> table_keys(table_size, kEmpty);
  std::vector<std::uint32_t> table_ids(table_size, 0);
  std::vector<std::uint64_t> voxel_keys;
  voxel_keys.reserve(n / 4 + 16);
  std::vector<std::uint32_t> point_voxel(n), counts;
  counts.reserve(n / 4 + 16);
  constexpr std::uint32_t kNone = ~std::uint32_t{0};
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t key = keys[i];
    if (key == kSkip) {
      point_voxel[i] = kNone;
      continue;
    }
    std::size_t slot = voxelProbeHash(key) & mask;
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
  const std::size_t voxels = voxel_keys.size();
  std::vector<std::uint32_t> start(voxels + 1, 0);
  for (std::size_t v = 0; v < voxels; ++v) start[v + 1] = start[v] + counts[v];
  std::vector<std::uint32_t> grouped(start.back());
  {
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (point_voxel[i] != kNone) grouped[fill[point_voxel[i]]++] = static_cast<std::uint32_t>(i);
  }
  std::vector<std::uint32_t> order(voxels);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return voxel_keys[a] < voxel_keys[b]; });

  return {std::move(start), std::move(grouped), std::move(order)};
}

// One pass over the points (keys in parallel, hashing serial), a counting sort to group them,
// then the voxels' centroids and votes in parallel. `crop` = keep only lo2 <= |p|² <= hi2.
// Non-finite points are dropped.
LabeledCloud downsample(const LabeledCloud& cloud, const VoxelDownsampleConfig& config,
                        const ClassTable& table, bool crop, double lo2, double hi2) {
  const VoxelGroups groups = groupByVoxel(pointKeys(cloud, config.voxel_size, crop, lo2, hi2));
  const std::vector<std::uint32_t>& start = groups.start;
  const std::vector<std::uint32_t>& grouped = groups.grouped;
  const std::vector<std::uint32_t>& order = groups.order;
  const std::size_t voxels = order.size();
  LabeledCloud out = LabeledCloud::withLayoutOf(cloud);
  out.resize(voxels);
  const bool has_i = cloud.hasIntensity(), has_t = cloud.hasTimestamps(), has_p = cloud.hasProperty();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, voxels, 512), [&](const auto& range) {
    std::vector<std::pair<ClassId, std::uint32_t>> votes;  // small: few classes per voxel
    for (std::size_t o = range.begin(); o < range.end(); ++o) {
      const std::uint32_t v = order[o];
      const std::size_t begin = start[v], end = start[v + 1];
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double si = 0, st = 0, sp = 0;
      std::size_t valued = 0;  // points with a property value (NaN = not observed)
      votes.clear();
      for (std::size_t k = begin; k < end; ++k) {
        const std::uint32_t i = grouped[k];
        sum += cloud.points[i].cast<double>();
        if (has_i) si += cloud.intensity[i];
        if (has_t) st += cloud.timestamps[i];
        if (has_p && !std::isnan(cloud.property[i])) {
          sp += cloud.property[i];
          ++valued;
        }
        const ClassId c = cloud.classes[i];
        auto it = std::find_if(votes.begin(), votes.end(), [c](const auto& e) { return e.first == c; });
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
      out.points[o] = (sum / count).cast<float>();
      out.classes[o] = cls;
      if (has_i) out.intensity[o] = static_cast<float>(si / count);
      if (has_t) out.timestamps[o] = st / count;
      // The mean of the values observed: a voxel is unobserved only if none of its points was.
      if (has_p) out.property[o] = valued ? static_cast<float>(sp / static_cast<double>(valued)) : std::nanf("");
    }
  });
  return out;
}

}  // namespace

VoxelDownsampleConfig propertyVoxels(double voxel_size) {
  VoxelDownsampleConfig c;
  c.voxel_size = voxel_size;
  c.vote = ClassVote::PreferProperty;
  return c;
}

LabeledCloud voxelDownsample(const LabeledCloud& cloud, const VoxelDownsampleConfig& config,
                             const ClassTable& table) {
  checkConfig(config);
  return downsample(cloud, config, table, false, 0.0, 0.0);
}

LabeledCloud cropAndDownsample(const LabeledCloud& cloud, const RangeCropConfig& crop,
                               const VoxelDownsampleConfig& config, const ClassTable& table) {
  if (!(crop.min_range >= 0.0) || !std::isfinite(crop.min_range))
    fail("range crop", "min_range must be >= 0 (got " + std::to_string(crop.min_range) + ")");
  if (!(crop.max_range > crop.min_range))
    fail("range crop", "max_range must be > min_range (got " + std::to_string(crop.max_range) + ")");
  checkConfig(config);
  return downsample(cloud, config, table, true, crop.min_range * crop.min_range,
                    crop.max_range * crop.max_range);
}

}  // namespace hazmap
