// A bag (ROS 1, rosbag2, MCAP) as a ScanSource: the LiDAR topic's messages become scans; the wheel
// odometry (and ground truth) topics, which arrive at their own rate, are interpolated at each
// scan's time. Scans wait in a short queue until the poses around their time have arrived. Times
// are the messages' header stamps (the time of the data, as tf uses them), never the log times.
#include <algorithm>
#include <deque>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/pose_buffer.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "io/io_detail.hpp"
#include "sources/imu_attach.hpp"
#include "sources/packet_decoders.hpp"
#include "sources/scan_assembler.hpp"
#include "sources/topic_selection.hpp"

namespace hazmap::sources {

namespace {

/// The first message of one topic, read with a reader of its own (metadata, class table).
std::optional<std::string> firstString(const std::filesystem::path& path, const TopicInfo& topic) {
  const auto reader = openBag(path);
  reader->selectTopics({topic.name});
  BagMessage m;
  if (!reader->next(m)) return std::nullopt;
  return decodeString(m.data, m.topic->serialization, path.string() + ": " + topic.name);
}

std::string readFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open the sensor metadata");
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class BagScanSource final : public ScanSource {
 public:
  BagScanSource(const std::filesystem::path& path, const ScanSourceOptions& options)
      : path_(path), options_(options), reader_(openBag(path)) {
    topics_ = selectTopics(reader_->topics(), options, path.string());
    for (const auto& line : topics_.skipped) notice(line);
    table_ = options.class_table ? *options.class_table : classTableOf();
    assembler_.emplace(topics_.kind, decoderFor());
    reader_->selectTopics(topics_.names());
  }

  std::optional<Scan> next() override {
    while (true) {
      if (!pending_.empty() && (exhausted_ || (posesCover(pending_.front().stamp) && imuCovers(pending_.front()))))
        return attachPoses();
      if (exhausted_) return std::nullopt;
      readMessage();
    }
  }
  std::optional<std::size_t> size() const override { return std::nullopt; }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override {
    return path_.string() + " " + topics_.lidar->name + " (" + assembler_->describe() + ")";
  }

 private:
  void notice(const std::string& line) const {
    if (options_.notice) options_.notice(line.rfind(path_.string(), 0) == 0 ? line : path_.string() + ": " + line);
  }

  ClassTable classTableOf() const {
    if (!topics_.class_table) return ClassTable::defaults();
    const auto yaml = firstString(path_, *topics_.class_table);
    if (!yaml) return ClassTable::defaults();
    return ClassTable::fromYamlString(*yaml, path_.string() + ": " + topics_.class_table->name);
  }

  std::unique_ptr<PacketDecoder> decoderFor() const {
    switch (topics_.kind) {
      case LidarKind::PointCloud2: return nullptr;
      case LidarKind::VelodyneScan: return makeVelodyneDecoderFor(options_);
      case LidarKind::HesaiScan: return makeHesaiDecoderFor(options_);
      case LidarKind::OusterPackets: break;
    }
    if (!options_.sensor_metadata.empty())
      return makeOusterDecoderFor(readFile(options_.sensor_metadata), options_.sensor_metadata.string());
    if (!topics_.ouster_metadata)
      fail(path_.string(), "Ouster packets on " + topics_.lidar->name +
                               " but no metadata topic; give the sensor's JSON with --sensor-metadata");
    const auto json = firstString(path_, *topics_.ouster_metadata);
    if (!json) fail(path_.string(), topics_.ouster_metadata->name + " has no message; use --sensor-metadata");
    return makeOusterDecoderFor(*json, path_.string() + ": " + topics_.ouster_metadata->name);
  }

  bool posesCover(double stamp) const {
    return (!topics_.odometry || odometry_.covers(stamp)) && (!topics_.ground_truth || truth_.covers(stamp));
  }

  void readMessage() {
    BagMessage m;
    if (!reader_->next(m)) {
      exhausted_ = true;
      for (const auto& line : assembler_->flush(path_.string() + ": " + topics_.lidar->name, pending_)) notice(line);
      imu_.append(assembler_->takeImu());
      for (const auto& line : reader_->loss().notices) notice(line);
      if (topics_.imu)
        if (const std::string line = imu_.notice(path_.string() + ": " + topics_.imu->name); !line.empty()) notice(line);
      return;
    }
    const std::string where = path_.string() + ": " + m.topic->name;
    if (m.topic->name == topics_.lidar->name) {
      assembler_->addMessage(m, where, pending_);
      imu_.append(assembler_->takeImu());
    } else if (topics_.odometry && m.topic->name == topics_.odometry->name) {
      const OdometryMsg o = decodeOdometry(m.data, m.topic->serialization, where);
      if (!odometry_.push(o.header.stamp, o.pose))
        notice(m.topic->name + ": odometry message older than the previous one skipped");
    } else if (topics_.imu && m.topic->name == topics_.imu->name) {
      readImu(m, where);
    } else if (topics_.ground_truth && m.topic->name == topics_.ground_truth->name) {
      const bool pose_stamped = m.topic->type == kPoseStampedType;
      const PoseStampedMsg p = pose_stamped ? decodePoseStamped(m.data, m.topic->serialization, where)
                                            : PoseStampedMsg{};
      const OdometryMsg o = pose_stamped ? OdometryMsg{} : decodeOdometry(m.data, m.topic->serialization, where);
      const double stamp = pose_stamped ? p.header.stamp : o.header.stamp;
      truth_.push(stamp, pose_stamped ? p.pose : o.pose);
    }
  }

  /// sensor_msgs/Imu samples are in the LiDAR's axes unless --imu-rotation gives R_lidar_imu (no
  /// tf lookup, as for the odometry); Ouster IMU packets go through the packet decoder, which
  /// rotates them by the metadata.
  void readImu(const BagMessage& m, const std::string& where) {
    if (topics_.imu_packets) {
      const LidarPacket p = decodeOusterPacket(m.data, m.topic->serialization, where);
      assembler_->addPacket(p.data, p.stamp > 0 ? p.stamp : static_cast<double>(m.log_time_ns) * 1e-9, where, pending_);
      imu_.append(assembler_->takeImu());
    } else {
      const ImuMsg msg = decodeImu(m.data, m.topic->serialization, where);
      const Eigen::Matrix3d R = options_.imu_rotation.value_or(Eigen::Matrix3d::Identity());
      imu_.append({ImuSample{msg.header.stamp, R * msg.angular_velocity, R * msg.linear_acceleration}});
    }
  }

  /// With an IMU topic, a scan also waits for the samples past its last point (a few scans at
  /// most: an IMU that stopped must not hold the recording in memory).
  bool imuCovers(const RawScan& raw) const {
    if (!topics_.imu || imu_.empty() || pending_.size() > 3) return true;
    const auto& t = raw.cloud.timestamps;
    return imu_.reaches(t.empty() ? raw.stamp : *std::max_element(t.begin(), t.end()));
  }

  Scan attachPoses() {
    RawScan raw = std::move(pending_.front());
    pending_.pop_front();
    Scan scan;
    scan.index = next_index_++;
    scan.stamp = raw.stamp;
    scan.cloud = std::move(raw.cloud);
    scan.cloud.classes.resize(scan.cloud.size(), 0);
    bool clamped = false;
    if (topics_.odometry) {
      scan.odometry = odometry_.at(scan.stamp, &clamped);
      if (clamped && !warned_clamp_++)
        notice("scan " + std::to_string(scan.index) + " at " + std::to_string(scan.stamp) + " s is outside " +
               topics_.odometry->name + "'s time span: the nearest odometry pose is used");
      odometry_.dropBefore(scan.stamp);
    }
    if (topics_.ground_truth) {
      scan.ground_truth = truth_.at(scan.stamp);
      truth_.dropBefore(scan.stamp);
    }
    if (!imu_.empty()) imu_.attach(scan, previous_stamp_);
    previous_stamp_ = scan.stamp;
    return scan;
  }

  std::filesystem::path path_;
  ScanSourceOptions options_;
  std::unique_ptr<MessageReader> reader_;
  SelectedTopics topics_;
  ClassTable table_;
  std::optional<ScanAssembler> assembler_;
  std::deque<RawScan> pending_;
  PoseBuffer odometry_, truth_;
  bool exhausted_ = false;
  std::size_t next_index_ = 0;
  int warned_clamp_ = 0;
  ImuBuffer imu_;
  std::optional<double> previous_stamp_;
};

}  // namespace

std::unique_ptr<ScanSource> openBagScanSource(const std::filesystem::path& path, const ScanSourceOptions& options) {
  return std::make_unique<BagScanSource>(path, options);
}

}  // namespace hazmap::sources
