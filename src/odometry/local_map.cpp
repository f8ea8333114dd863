#include "hazmap/odometry/local_map.hpp"

#include <cmath>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

std::uint64_t packKey(std::int64_t x, std::int64_t y, std::int64_t z) {
  const auto f = [](std::int64_t v) { return static_cast<std::uint64_t>(v + (1LL << 20)) & 0x1FFFFFu; };
  return (f(x) << 42) | (f(y) << 21) | f(z);
}

}  // namespace

void LocalMapConfig::validate() const {
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size))
    fail("local map", "voxel_size must be > 0 (got " + std::to_string(voxel_size) + ")");
  if (max_points_per_voxel < 1) fail("local map", "max_points_per_voxel must be >= 1");
  if (!(min_point_distance >= 0.0) || !std::isfinite(min_point_distance))
    fail("local map", "min_point_distance must be >= 0");
  if (!(max_distance > 0.0) || !std::isfinite(max_distance))
    fail("local map", "max_distance must be > 0 (got " + std::to_string(max_distance) + ")");
}

LocalMap::LocalMap(const LocalMapConfig& config) : config_(config) { config_.validate(); }

void LocalMap::clear() {
  voxels_.clear();
  index_.clear();
  points_ = 0;
}

void LocalMap::integrate(const LabeledCloud& scan, const Eigen::Vector3d& origin, const ClassTable& table) {
  const double inv = 1.0 / config_.voxel_size;
  const float min_d2 = static_cast<float>(config_.min_point_distance * config_.min_point_distance);
  if (points_ == 0) has_values_ = scan.hasProperty();
  const bool values = has_values_ && scan.hasProperty();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3f& p = scan.points[i];
    if (!p.allFinite()) continue;
    const auto x = static_cast<std::int64_t>(std::floor(p.x() * inv));
    const auto y = static_cast<std::int64_t>(std::floor(p.y() * inv));
    const auto z = static_cast<std::int64_t>(std::floor(p.z() * inv));
    const std::uint64_t key = packKey(x, y, z);
    auto [it, inserted] = index_.try_emplace(key, static_cast<std::uint32_t>(voxels_.size()));
    if (inserted) voxels_.push_back(Voxel{x, y, z, {}, {}, {}, 0});
    Voxel& v = voxels_[it->second];
    const ClassId cls = scan.classes[i];
    const bool prop = table.isProperty(cls);
    if (min_d2 > 0.0f) {
      bool close = false;
      for (std::size_t k = 0; k < v.points.size() && !close; ++k)
        close = (v.points[k] - p).squaredNorm() < min_d2 && (!prop || v.classes[k] == cls);
      if (close) continue;
    }
    const float value = values ? scan.property[i] : 0.0f;
    if (static_cast<int>(v.points.size()) < config_.max_points_per_voxel) {
      v.points.push_back(p);
      v.classes.push_back(cls);
      v.values.push_back(value);
      v.property_points += prop;
      ++points_;
    } else if (prop && 2 * v.property_points < config_.max_points_per_voxel) {
      // Replace the oldest unlabelled point.
      for (std::size_t k = 0; k < v.points.size(); ++k) {
        if (table.isProperty(v.classes[k])) continue;
        v.points[k] = p;
        v.classes[k] = cls;
        v.values[k] = value;
        ++v.property_points;
        break;
      }
    }
  }
  // Bound the map: drop voxels far from the robot (swap-remove keeps it O(1) and deterministic).
  const double max_d2 = config_.max_distance * config_.max_distance;
  for (std::size_t k = 0; k < voxels_.size();) {
    const Voxel& v = voxels_[k];
    const Eigen::Vector3d centre((v.x + 0.5) * config_.voxel_size, (v.y + 0.5) * config_.voxel_size,
                                 (v.z + 0.5) * config_.voxel_size);
    if ((centre - origin).squaredNorm() <= max_d2) {
      ++k;
      continue;
    }
    points_ -= v.points.size();
    index_.erase(packKey(v.x, v.y, v.z));
    if (k + 1 != voxels_.size()) {
      voxels_[k] = std::move(voxels_.back());
      index_[packKey(voxels_[k].x, voxels_[k].y, voxels_[k].z)] = static_cast<std::uint32_t>(k);
    }
    voxels_.pop_back();
  }
}

LabeledCloud LocalMap::cloud() const {
  LabeledCloud out;
  if (has_values_) out.enableProperty();
  out.reserve(points_);
  for (const Voxel& v : voxels_)
    for (std::size_t k = 0; k < v.points.size(); ++k) out.push_back(v.points[k], v.classes[k], 0.0f, 0.0, v.values[k]);
  return out;
}

}  // namespace hazmap
