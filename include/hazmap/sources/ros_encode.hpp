#pragma once
// ROS 2 CDR encoders of the messages hazmap writes (simulate --format mcap) and a LabeledCloud →
// PointCloud2 conversion. The inverse of ros_messages.hpp's decoders for these types.
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap {

/// CDR with its encapsulation header: little-endian (ROS 2's) unless `big_endian`.
std::vector<std::uint8_t> encodePointCloud2(const PointCloud2& msg, bool big_endian = false);
std::vector<std::uint8_t> encodeOdometry(const OdometryMsg& msg, bool big_endian = false);
std::vector<std::uint8_t> encodeImage(const ImageMsg& msg, bool big_endian = false);
/// sensor_msgs/Imu with no orientation (covariance[0] = −1, as REP 145 says) and zero covariances.
std::vector<std::uint8_t> encodeImu(const ImuMsg& msg, bool big_endian = false);
std::vector<std::uint8_t> encodeCompressedImage(const CompressedImageMsg& msg, bool big_endian = false);
/// geometry_msgs/msg/PoseStamped.
std::vector<std::uint8_t> encodePoseStamped(const RosHeader& header, const Eigen::Isometry3d& pose,
                                            bool big_endian = false);
std::vector<std::uint8_t> encodeString(const std::string& text, bool big_endian = false);

/// A cloud as a packed PointCloud2 (height 1): x y z float32; intensity float32, `class`
/// uint16, `property` float32 and `time` float32 (seconds relative to header.stamp) when the
/// cloud has those channels.
PointCloud2 cloudToPointCloud2(const LabeledCloud& cloud, const RosHeader& header);

/// Decoders of geometry_msgs/msg/PoseStamped (what /ground_truth carries).
struct PoseStampedMsg {
  RosHeader header;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
};
PoseStampedMsg decodePoseStamped(std::span<const std::uint8_t> bytes, Serialization s,
                                 const std::string& where);

}  // namespace hazmap
