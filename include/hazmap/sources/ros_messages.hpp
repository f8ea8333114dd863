#pragma once
// Decoders of the ROS message types hazmap consumes, from ROS 2 CDR or ROS 1 serialization.
// Every decoder checks lengths and counts and throws hazmap::Error("<where>: <what>") on a
// truncated or inconsistent message; `where` names the file/topic/offset given by the caller.
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/sources/bag_message.hpp"

namespace hazmap {

struct RosHeader {
  double stamp = 0.0;  ///< seconds
  std::string frame_id;
};

struct PointField {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;  ///< sensor_msgs/PointField: INT8=1 … FLOAT64=8
  std::uint32_t count = 1;
};

struct PointCloud2 {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::vector<PointField> fields;
  bool is_bigendian = false;
  std::uint32_t point_step = 0, row_step = 0;
  std::vector<std::uint8_t> data;
  bool is_dense = false;
};

struct OdometryMsg {
  RosHeader header;
  std::string child_frame_id;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  Eigen::Matrix<double, 6, 6> pose_covariance = Eigen::Matrix<double, 6, 6>::Zero();  ///< ROS order
};

/// sensor_msgs/Imu: the rates and the specific force (orientation and covariances not used).
struct ImuMsg {
  RosHeader header;
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();     ///< rad/s
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  ///< m/s²
};

struct ImageMsg {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string encoding;  ///< "mono16", "32FC1", "mono8", ...
  bool is_bigendian = false;
  std::uint32_t step = 0;
  std::vector<std::uint8_t> data;
};

/// sensor_msgs/CompressedImage: `format` as image_transport writes it ("png", "jpeg",
/// "mono16; png compressed", "bgr8; jpeg compressed bgr8"), `data` the encoded file.
struct CompressedImageMsg {
  RosHeader header;
  std::string format;
  std::vector<std::uint8_t> data;
};

/// One raw UDP payload of a Velodyne (velodyne_msgs/VelodynePacket) or an Ouster
/// (ouster_ros/PacketMsg) sensor.
struct LidarPacket {
  double stamp = 0.0;  ///< seconds (0 when the message has none)
  std::vector<std::uint8_t> data;
};

struct VelodyneScanMsg {
  RosHeader header;
  std::vector<LidarPacket> packets;
};

PointCloud2 decodePointCloud2(std::span<const std::uint8_t> bytes, Serialization s,
                              const std::string& where);
OdometryMsg decodeOdometry(std::span<const std::uint8_t> bytes, Serialization s,
                           const std::string& where);
ImageMsg decodeImage(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);
CompressedImageMsg decodeCompressedImage(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);
VelodyneScanMsg decodeVelodyneScan(std::span<const std::uint8_t> bytes, Serialization s,
                                   const std::string& where);
/// pandar_msgs/msg/PandarScan (the Hesai drivers' packet topic): header, PandarPacket[] with
/// {builtin_interfaces/Time stamp, uint8[1500] data, uint32 size}; each packet's first `size`
/// bytes (size > 1500 is an error naming `where`).
VelodyneScanMsg decodePandarScan(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);
LidarPacket decodeOusterPacket(std::span<const std::uint8_t> bytes, Serialization s,
                               const std::string& where);
/// sensor_msgs/Imu (ROS 2 CDR or ROS 1); a truncated message or a non-finite rate or
/// acceleration is an error naming `where`.
ImuMsg decodeImu(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);
/// std_msgs/String (the Ouster driver's metadata topic).
std::string decodeString(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);

/// A PointCloud2 of any field layout (offsets, types, endianness, padding, height > 1) as a
/// LabeledCloud: x y z required; `intensity` (or `reflectivity`) → intensity; the per-point
/// time field (`time`/`t`/`timestamp`/`time_stamp`, s or ns, relative or absolute) → timestamps
/// in absolute seconds; a `class`/`label` field → classes. Points with a non-finite coordinate
/// or all-zero xyz (no return) are dropped.
LabeledCloud pointCloud2ToCloud(const PointCloud2& msg, const std::string& where);

}  // namespace hazmap
