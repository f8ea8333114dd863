#pragma once
// Which topics of a bag a scan stream reads: the LiDAR topic (PointCloud2, VelodyneScan, Hesai
// PandarScan or Ouster packets), the wheel odometry, and what comes with them (Ouster metadata, ground truth, a
// hazmap class table). Defaults: the only candidate; ambiguous or wrong → one line listing the
// candidates with their types.
#include <string>
#include <vector>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::sources {

enum class LidarKind { PointCloud2, VelodyneScan, OusterPackets, HesaiScan };

inline constexpr const char* kPointCloud2Type = "sensor_msgs/msg/PointCloud2";
inline constexpr const char* kVelodyneScanType = "velodyne_msgs/msg/VelodyneScan";
inline constexpr const char* kPandarScanType = "pandar_msgs/msg/PandarScan";
inline constexpr const char* kOdometryType = "nav_msgs/msg/Odometry";
inline constexpr const char* kStringType = "std_msgs/msg/String";
inline constexpr const char* kPoseStampedType = "geometry_msgs/msg/PoseStamped";
inline constexpr const char* kImuType = "sensor_msgs/msg/Imu";
/// hazmap's own bags (simulate --format mcap) carry their class table as YAML on this topic.
inline constexpr const char* kClassTableTopic = "/hazmap/class_table";
inline constexpr const char* kGroundTruthTopic = "/ground_truth";

struct SelectedTopics {
  const TopicInfo* lidar = nullptr;
  LidarKind kind = LidarKind::PointCloud2;
  const TopicInfo* odometry = nullptr;         ///< nullptr: no wheel odometry
  const TopicInfo* ouster_metadata = nullptr;  ///< std_msgs/String …/metadata (Ouster packets only)
  const TopicInfo* ground_truth = nullptr;     ///< /ground_truth PoseStamped or Odometry
  const TopicInfo* class_table = nullptr;      ///< /hazmap/class_table
  /// The IMU: the only sensor_msgs/Imu topic, or (Ouster packets) the driver's …/imu_packets
  /// beside the lidar packets; nullptr when none (or several Imu topics: named in `skipped`).
  const TopicInfo* imu = nullptr;
  bool imu_packets = false;  ///< `imu` carries Ouster IMU packets (else sensor_msgs/Imu)
  /// Topics not read, one line each ("/camera/image (sensor_msgs/msg/Image): not a LiDAR …").
  std::vector<std::string> skipped;
  std::vector<std::string> names() const;  ///< the selected topics' names
};

/// The LiDAR kind a message type is, if it is one.
bool lidarKindOf(const TopicInfo& topic, LidarKind& kind);
/// "/a (type), /b (type)".
std::string listTopics(const std::vector<const TopicInfo*>& topics);

SelectedTopics selectTopics(const std::vector<TopicInfo>& topics, const ScanSourceOptions& options,
                            const std::string& where);

}  // namespace hazmap::sources
