// Decoders of the ROS messages hazmap consumes (sensor_msgs, nav_msgs, velodyne_msgs,
// ouster_ros, std_msgs), from CDR or ROS 1 serialization. Field order follows the .msg files.
#include "hazmap/sources/ros_messages.hpp"

#include <cmath>

#include "ros_reader.hpp"

namespace hazmap {

using sources::RosReader;

namespace {

constexpr std::size_t kVelodynePacketBytes = 1206;

PointField readPointField(RosReader& r) {
  PointField f;
  f.name = r.string();
  f.offset = r.prim<std::uint32_t>();
  f.datatype = r.prim<std::uint8_t>();
  f.count = r.prim<std::uint32_t>();
  return f;
}

Eigen::Isometry3d readPose(RosReader& r) {
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) t[i] = r.prim<double>();
  double q[4];
  for (double& v : q) v = r.prim<double>();
  Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
  if (!t.allFinite() || !quat.coeffs().allFinite() || quat.norm() < 1e-6)
    r.failAt("pose with a non-finite position or an invalid quaternion");
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = quat.normalized().toRotationMatrix();
  pose.translation() = t;
  return pose;
}

}  // namespace

PointCloud2 decodePointCloud2(std::span<const std::uint8_t> bytes, Serialization s,
                              const std::string& where) {
  RosReader r(bytes, s, where);
  PointCloud2 msg;
  msg.header = r.header();
  msg.height = r.prim<std::uint32_t>();
  msg.width = r.prim<std::uint32_t>();
  const auto n_fields = r.count(9, "PointField");
  msg.fields.reserve(n_fields);
  for (std::uint32_t i = 0; i < n_fields; ++i) msg.fields.push_back(readPointField(r));
  msg.is_bigendian = r.prim<std::uint8_t>() != 0;
  msg.point_step = r.prim<std::uint32_t>();
  msg.row_step = r.prim<std::uint32_t>();
  const auto data = r.byteSequence("PointCloud2 data");
  msg.data.assign(data.begin(), data.end());
  msg.is_dense = r.prim<std::uint8_t>() != 0;
  return msg;
}

OdometryMsg decodeOdometry(std::span<const std::uint8_t> bytes, Serialization s,
                           const std::string& where) {
  RosReader r(bytes, s, where);
  OdometryMsg msg;
  msg.header = r.header();
  msg.child_frame_id = r.string();
  msg.pose = readPose(r);
  for (int i = 0; i < 36; ++i) msg.pose_covariance(i / 6, i % 6) = r.prim<double>();
  r.skipDoubles(6 + 36);  // twist and its covariance: checked present, not used
  return msg;
}

ImuMsg decodeImu(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where) {
  RosReader r(bytes, s, where);
  ImuMsg msg;
  msg.header = r.header();
  r.skipDoubles(4 + 9);  // orientation and its covariance
  for (int k = 0; k < 3; ++k) msg.angular_velocity[k] = r.prim<double>();
  r.skipDoubles(9);
  for (int k = 0; k < 3; ++k) msg.linear_acceleration[k] = r.prim<double>();
  r.skipDoubles(9);
  if (!msg.angular_velocity.allFinite() || !msg.linear_acceleration.allFinite())
    r.failAt("Imu with a non-finite angular velocity or linear acceleration");
  return msg;
}

ImageMsg decodeImage(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where) {
  RosReader r(bytes, s, where);
  ImageMsg msg;
  msg.header = r.header();
  msg.height = r.prim<std::uint32_t>();
  msg.width = r.prim<std::uint32_t>();
  msg.encoding = r.string();
  msg.is_bigendian = r.prim<std::uint8_t>() != 0;
  msg.step = r.prim<std::uint32_t>();
  const auto data = r.byteSequence("Image data");
  if (static_cast<std::uint64_t>(msg.step) * msg.height > data.size())
    r.failAt("Image of " + std::to_string(msg.height) + " rows of " + std::to_string(msg.step) +
             " bytes has only " + std::to_string(data.size()) + " data bytes");
  msg.data.assign(data.begin(), data.end());
  return msg;
}

CompressedImageMsg decodeCompressedImage(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where) {
  RosReader r(bytes, s, where);
  CompressedImageMsg msg;
  msg.header = r.header();
  msg.format = r.string();
  const auto data = r.byteSequence("CompressedImage data");
  msg.data.assign(data.begin(), data.end());
  return msg;
}

VelodyneScanMsg decodeVelodyneScan(std::span<const std::uint8_t> bytes, Serialization s,
                                   const std::string& where) {
  RosReader r(bytes, s, where);
  VelodyneScanMsg msg;
  msg.header = r.header();
  const auto n = r.count(8 + kVelodynePacketBytes, "VelodynePacket");
  msg.packets.resize(n);
  for (auto& packet : msg.packets) {
    packet.stamp = r.time();
    const auto data = r.fixedBytes(kVelodynePacketBytes, "VelodynePacket data");
    packet.data.assign(data.begin(), data.end());
  }
  return msg;
}

VelodyneScanMsg decodePandarScan(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where) {
  constexpr std::size_t kPandarPacketBytes = 1500;
  RosReader r(bytes, s, where);
  VelodyneScanMsg msg;
  msg.header = r.header();
  const auto n = r.count(8 + kPandarPacketBytes + 4, "PandarPacket");
  msg.packets.resize(n);
  for (auto& packet : msg.packets) {
    packet.stamp = r.time();
    const auto data = r.fixedBytes(kPandarPacketBytes, "PandarPacket data");
    const auto size = r.prim<std::uint32_t>();
    if (size > kPandarPacketBytes)
      r.failAt("PandarPacket size " + std::to_string(size) + " exceeds its 1500 data bytes");
    packet.data.assign(data.begin(), data.begin() + size);
  }
  return msg;
}

LidarPacket decodeOusterPacket(std::span<const std::uint8_t> bytes, Serialization s,
                               const std::string& where) {
  RosReader r(bytes, s, where);
  LidarPacket packet;
  const auto data = r.byteSequence("PacketMsg buf");
  packet.data.assign(data.begin(), data.end());
  return packet;
}

std::string decodeString(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where) {
  RosReader r(bytes, s, where);
  return r.string();
}

}  // namespace hazmap
