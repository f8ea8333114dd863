#pragma once
// A scan stream written as a ROS 2 MCAP bag, as a robot's recorder would have written it:
// /velodyne_points (sensor_msgs/msg/PointCloud2 with a `class` field, and `time` when the scans
// have per-point times), /odom (nav_msgs/msg/Odometry) when the scans have wheel odometry,
// /ground_truth (geometry_msgs/msg/PoseStamped) when they have ground truth, and the class table
// as YAML on /hazmap/class_table (std_msgs/msg/String), so the bag reads back with its classes.
// Used by `hazmap simulate --format mcap`.
#include <filesystem>

#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

struct McapExportSummary {
  std::size_t scans = 0, odometry = 0, ground_truth = 0;
};

/// Writes every scan of `scans` into `path` (atomically: nothing is left on an error).
McapExportSummary writeScansAsMcap(ScanSource& scans, const std::filesystem::path& path);

}  // namespace hazmap
