#pragma once
// The local map of frame-to-map odometry: a sparse voxel map in the world frame that keeps a few
// points per voxel *with their classes*, bounded to a radius around the robot. Property points are
// rare and carry the paper's signal, so a full voxel still accepts one by replacing an unlabelled
// point, as long as property points hold at most half of it.
#include <Eigen/Core>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

struct LocalMapConfig {
  double voxel_size = 1.0;        ///< m (> 0)
  int max_points_per_voxel = 20;  ///< >= 1
  /// Points closer than this to a point already in the voxel are not added (m; 0 = off): keeps the
  /// map from filling with repeated returns of the same surface.
  double min_point_distance = 0.0;
  double max_distance = 100.0;    ///< m; voxels farther from the robot are dropped (> 0)
  void validate() const;
};

class LocalMap {
 public:
  explicit LocalMap(const LocalMapConfig& config = {});

  /// Adds `scan_world` (already in the world frame) and drops voxels farther than max_distance
  /// from `origin`. `table` tells which classes are properties. Deterministic.
  void integrate(const LabeledCloud& scan_world, const Eigen::Vector3d& origin, const ClassTable& table);
  /// Every point in the map (classes and property values kept), in a deterministic order.
  LabeledCloud cloud() const;
  std::size_t size() const { return points_; }
  std::size_t voxels() const { return voxels_.size(); }
  bool empty() const { return points_ == 0; }
  void clear();

 private:
  struct Voxel {
    std::int64_t x, y, z;
    std::vector<Eigen::Vector3f> points;
    std::vector<ClassId> classes;
    std::vector<float> values;
    int property_points = 0;
  };
  LocalMapConfig config_;
  std::vector<Voxel> voxels_;
  std::unordered_map<std::uint64_t, std::uint32_t> index_;  ///< voxel key → position in voxels_
  std::size_t points_ = 0;
  bool has_values_ = false;
};

}  // namespace hazmap
