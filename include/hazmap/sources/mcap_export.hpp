#pragma once
// A scan stream written as a ROS 2 MCAP bag, as a robot's recorder would have written it:
// /velodyne_points (sensor_msgs/msg/PointCloud2 with a `class` field, and `time` when the scans
// have per-point times), /odom (nav_msgs/msg/Odometry) when the scans have wheel odometry,
// /ground_truth (geometry_msgs/msg/PoseStamped) when they have ground truth, and the class table
// as YAML on /hazmap/class_table (std_msgs/msg/String), so the bag reads back with its classes.
// Used by `hazmap simulate --format mcap`.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

struct McapExportSummary {
  std::size_t scans = 0, odometry = 0, ground_truth = 0;
};

/// Further messages beside the scans (e.g. a camera's sensor_msgs/msg/Image), logged at their stamps.
struct McapExtraTopic {
  std::string topic, type;
  std::vector<double> stamps;  ///< s, one per message
  std::function<std::vector<std::uint8_t>(std::size_t)> message;  ///< CDR bytes of message i (made when written)
};

/// Writes every scan of `scans` into `path` (atomically: nothing is left on an error), and the
/// messages of `extra`, each before the first scan later than it.
McapExportSummary writeScansAsMcap(ScanSource& scans, const std::filesystem::path& path,
                                   const std::vector<McapExtraTopic>& extra = {});

}  // namespace hazmap
