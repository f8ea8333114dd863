#pragma once
// Voxel-grid downsampling that keeps classes: one point per occupied voxel at the centroid of its
// points, optional channels averaged, and a class chosen by vote.
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/preprocess/crop.hpp"

namespace hazmap {

enum class ClassVote {
  Majority,        ///< the most frequent class in the voxel (ties → smaller id); for maps
  PreferProperty,  ///< a property class wins if it holds >= `property_share` of the voxel's
                   ///< points; property points are rare and carry the paper's signal (sec. IV-B)
};

struct VoxelDownsampleConfig {
  double voxel_size = 0.25;  ///< m, must be > 0
  ClassVote vote = ClassVote::Majority;
  double property_share = 0.25;  ///< for PreferProperty
};

/// Registration's and loop closure's downsampling: `voxel_size`, a property class winning its voxel
/// at property_share (ClassVote::PreferProperty). Every cloud that is matched against another
/// (tracking, loops, global registration, priors) is made this way, so their labels agree.
VoxelDownsampleConfig propertyVoxels(double voxel_size);

/// Deterministic: output order follows the voxels' sorted keys (and does not depend on the number
/// of threads; key computation and per-voxel averaging run in parallel). Non-finite points are
/// dropped. `table` tells which classes are properties (needed for PreferProperty). Throws
/// hazmap::Error on voxel_size <= 0.
LabeledCloud voxelDownsample(const LabeledCloud& cloud, const VoxelDownsampleConfig& config,
                             const ClassTable& table = ClassTable::defaults());

/// cropRange followed by voxelDownsample in one pass, without the cropped copy: same output as
/// voxelDownsample(cropRange(cloud, crop), config, table). Throws hazmap::Error on a bad config.
LabeledCloud cropAndDownsample(const LabeledCloud& cloud, const RangeCropConfig& crop,
                               const VoxelDownsampleConfig& config,
                               const ClassTable& table = ClassTable::defaults());

}  // namespace hazmap
