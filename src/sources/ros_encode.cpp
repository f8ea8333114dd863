// CDR encoding: primitives aligned to their size counted from the end of the 4-byte
// encapsulation header, strings as uint32 length (with the NUL) + bytes + NUL.
#include "hazmap/sources/ros_encode.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "ros_reader.hpp"

namespace hazmap {
namespace {

class CdrWriter {
 public:
  explicit CdrWriter(bool big_endian) : big_(big_endian) {
    out_ = {0x00, static_cast<std::uint8_t>(big_endian ? 0x00 : 0x01), 0x00, 0x00};
  }
  template <class T>
  void prim(T v) {
    const std::size_t a = sizeof(T);
    while ((out_.size() - 4) % a) out_.push_back(0);
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    if (big_ != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof(T));
    out_.insert(out_.end(), b, b + sizeof(T));
  }
  void string(const std::string& s) {
    prim<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    out_.insert(out_.end(), s.begin(), s.end());
    out_.push_back(0);
  }
  void bytes(const std::vector<std::uint8_t>& data) {
    prim<std::uint32_t>(static_cast<std::uint32_t>(data.size()));
    out_.insert(out_.end(), data.begin(), data.end());
  }
  void header(const RosHeader& h) {
    const double sec = std::floor(h.stamp);
    auto nsec = static_cast<std::int64_t>(std::llround((h.stamp - sec) * 1e9));
    auto isec = static_cast<std::int64_t>(sec);
    if (nsec >= 1000000000) nsec -= 1000000000, ++isec;
    prim<std::int32_t>(static_cast<std::int32_t>(isec));
    prim<std::uint32_t>(static_cast<std::uint32_t>(nsec));
    string(h.frame_id);
  }
  void pose(const Eigen::Isometry3d& T) {
    for (int i = 0; i < 3; ++i) prim<double>(T.translation()[i]);
    const Eigen::Quaterniond q(T.linear());
    prim<double>(q.x());
    prim<double>(q.y());
    prim<double>(q.z());
    prim<double>(q.w());
  }
  /// The serialized payload padded to a multiple of 4, as ROS 2's DDS layers send it.
  std::vector<std::uint8_t> take() {
    while (out_.size() % 4) out_.push_back(0);
    return std::move(out_);
  }

 private:
  std::vector<std::uint8_t> out_;
  bool big_;
};

}  // namespace

std::vector<std::uint8_t> encodePointCloud2(const PointCloud2& msg, bool big_endian) {
  CdrWriter w(big_endian);
  w.header(msg.header);
  w.prim<std::uint32_t>(msg.height);
  w.prim<std::uint32_t>(msg.width);
  w.prim<std::uint32_t>(static_cast<std::uint32_t>(msg.fields.size()));
  for (const auto& f : msg.fields) {
    w.string(f.name);
    w.prim<std::uint32_t>(f.offset);
    w.prim<std::uint8_t>(f.datatype);
    w.prim<std::uint32_t>(f.count);
  }
  w.prim<std::uint8_t>(msg.is_bigendian ? 1 : 0);
  w.prim<std::uint32_t>(msg.point_step);
  w.prim<std::uint32_t>(msg.row_step);
  w.bytes(msg.data);
  w.prim<std::uint8_t>(msg.is_dense ? 1 : 0);
  return w.take();
}

std::vector<std::uint8_t> encodeOdometry(const OdometryMsg& msg, bool big_endian) {
  CdrWriter w(big_endian);
  w.header(msg.header);
  w.string(msg.child_frame_id);
  w.pose(msg.pose);
  for (int i = 0; i < 36; ++i) w.prim<double>(msg.pose_covariance(i / 6, i % 6));
  for (int i = 0; i < 6 + 36; ++i) w.prim<double>(0.0);  // twist + covariance
  return w.take();
}

std::vector<std::uint8_t> encodeImu(const ImuMsg& msg, bool big_endian) {
  CdrWriter w(big_endian);
  w.header(msg.header);
  for (double q : {0.0, 0.0, 0.0, 1.0}) w.prim<double>(q);
  for (int i = 0; i < 9; ++i) w.prim<double>(i == 0 ? -1.0 : 0.0);  // no orientation estimate
  for (int k = 0; k < 3; ++k) w.prim<double>(msg.angular_velocity[k]);
  for (int i = 0; i < 9; ++i) w.prim<double>(0.0);
  for (int k = 0; k < 3; ++k) w.prim<double>(msg.linear_acceleration[k]);
  for (int i = 0; i < 9; ++i) w.prim<double>(0.0);
  return w.take();
}

std::vector<std::uint8_t> encodeImage(const ImageMsg& msg, bool big_endian) {
  CdrWriter w(big_endian);
  w.header(msg.header);
  w.prim<std::uint32_t>(msg.height);
  w.prim<std::uint32_t>(msg.width);
  w.string(msg.encoding);
  w.prim<std::uint8_t>(msg.is_bigendian ? 1 : 0);
  w.prim<std::uint32_t>(msg.step);
  w.bytes(msg.data);
  return w.take();
}

std::vector<std::uint8_t> encodeCompressedImage(const CompressedImageMsg& msg, bool big_endian) {
  CdrWriter w(big_endian);
  w.header(msg.header);
  w.string(msg.format);
  w.bytes(msg.data);
  return w.take();
}

std::vector<std::uint8_t> encodePoseStamped(const RosHeader& header, const Eigen::Isometry3d& pose,
                                            bool big_endian) {
  CdrWriter w(big_endian);
  w.header(header);
  w.pose(pose);
  return w.take();
}

std::vector<std::uint8_t> encodeString(const std::string& text, bool big_endian) {
  CdrWriter w(big_endian);
  w.string(text);
  return w.take();
}

PoseStampedMsg decodePoseStamped(std::span<const std::uint8_t> bytes, Serialization s,
                                 const std::string& where) {
  sources::RosReader r(bytes, s, where);
  PoseStampedMsg msg;
  msg.header = r.header();
  Eigen::Vector3d t;
  for (int i = 0; i < 3; ++i) t[i] = r.prim<double>();
  double q[4];
  for (double& v : q) v = r.prim<double>();
  const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
  if (!t.allFinite() || !quat.coeffs().allFinite() || quat.norm() < 1e-6)
    r.failAt("PoseStamped with a non-finite position or an invalid quaternion");
  msg.pose.linear() = quat.normalized().toRotationMatrix();
  msg.pose.translation() = t;
  return msg;
}

PointCloud2 cloudToPointCloud2(const LabeledCloud& cloud, const RosHeader& header) {
  PointCloud2 msg;
  msg.header = header;
  msg.height = 1;
  msg.width = static_cast<std::uint32_t>(cloud.size());
  auto add = [&](const char* name, std::uint8_t type, std::uint32_t size) {
    msg.fields.push_back({name, msg.point_step, type, 1});
    msg.point_step += size;
  };
  add("x", 7, 4), add("y", 7, 4), add("z", 7, 4);
  const bool intensity = cloud.hasIntensity(), time = cloud.hasTimestamps(), property = cloud.hasProperty();
  if (intensity) add("intensity", 7, 4);
  if (time) add("time", 7, 4);
  if (property) add("property", 7, 4);
  add("class", 4, 2);
  msg.row_step = msg.point_step * msg.width;
  msg.data.resize(msg.row_step);
  msg.is_dense = true;
  msg.is_bigendian = std::endian::native == std::endian::big;
  std::uint8_t* out = msg.data.data();
  auto put = [&out](auto v) {
    std::memcpy(out, &v, sizeof v);
    out += sizeof v;
  };
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    put(cloud.points[i].x()), put(cloud.points[i].y()), put(cloud.points[i].z());
    if (intensity) put(cloud.intensity[i]);
    if (time) put(static_cast<float>(cloud.timestamps[i] - header.stamp));
    if (property) put(cloud.property[i]);
    put(static_cast<std::uint16_t>(cloud.classes[i]));
  }
  return msg;
}

}  // namespace hazmap
