#include "sources/topic_selection.hpp"

#include "hazmap/core/error.hpp"

namespace hazmap::sources {

namespace {

bool isOusterPacketType(const std::string& type) {
  return type == "ouster_ros/msg/PacketMsg" || type == "ouster_sensor_msgs/msg/PacketMsg";
}

bool contains(const std::string& s, const char* part) { return s.find(part) != std::string::npos; }

/// The one topic among `candidates` named `wanted` (or the only candidate when `wanted` is
/// empty); errors list the candidates. nullptr when optional and there is none.
const TopicInfo* pick(const std::vector<const TopicInfo*>& candidates, const std::vector<TopicInfo>& all,
                      const std::string& wanted, const char* what, const char* flag, bool required,
                      const std::string& where) {
  std::vector<const TopicInfo*> every;
  for (const auto& t : all) every.push_back(&t);
  if (!wanted.empty()) {
    for (const TopicInfo* t : candidates)
      if (t->name == wanted) return t;
    for (const TopicInfo* t : every)
      if (t->name == wanted)
        fail(where, std::string(flag) + " '" + wanted + "' is " + t->type + ", not a " + what + " topic; " +
                        what + " topics: " + (candidates.empty() ? "none" : listTopics(candidates)));
    fail(where, std::string(flag) + " '" + wanted + "' not found; " + what + " topics: " +
                    (candidates.empty() ? "none" : listTopics(candidates)) + "; all topics: " + listTopics(every));
  }
  if (candidates.size() == 1) return candidates.front();
  if (candidates.empty()) {
    if (!required) return nullptr;
    fail(where, std::string("no ") + what + " topic (PointCloud2, velodyne_msgs/VelodyneScan, pandar_msgs/PandarScan or Ouster "
                                            "packets); topics: " + (every.empty() ? "none" : listTopics(every)));
  }
  fail(where, std::string(candidates.size() > 1 ? "several " : "") + what + " topics, choose one with " + flag +
                  ": " + listTopics(candidates));
}

/// The only sensor_msgs/Imu topic; else, for Ouster packets, the driver's imu_packets topic of
/// the same namespace. Several Imu topics: none (each is named as not read).
const TopicInfo* pickImu(const std::vector<TopicInfo>& topics, const SelectedTopics& s, bool& packets) {
  std::vector<const TopicInfo*> imus;
  for (const auto& t : topics)
    if (t.type == kImuType && (t.serialization == Serialization::Cdr || t.serialization == Serialization::Ros1))
      imus.push_back(&t);
  packets = false;
  if (imus.size() == 1) return imus.front();
  if (!imus.empty() || s.kind != LidarKind::OusterPackets) return nullptr;
  const std::string ns = s.lidar->name.substr(0, s.lidar->name.rfind('/'));
  for (const auto& t : topics)
    if (isOusterPacketType(t.type) && contains(t.name, "imu") && t.name.rfind(ns, 0) == 0) {
      packets = true;
      return &t;
    }
  return nullptr;
}

}  // namespace

bool lidarKindOf(const TopicInfo& topic, LidarKind& kind) {
  if (topic.type == kPointCloud2Type) kind = LidarKind::PointCloud2;
  else if (topic.type == kVelodyneScanType) kind = LidarKind::VelodyneScan;
  else if (topic.type == kPandarScanType) kind = LidarKind::HesaiScan;
  // The Ouster driver sends IMU packets with the same message type on …/imu_packets.
  else if (isOusterPacketType(topic.type) && !contains(topic.name, "imu")) kind = LidarKind::OusterPackets;
  else return false;
  return true;
}

std::string listTopics(const std::vector<const TopicInfo*>& topics) {
  std::string out;
  for (const TopicInfo* t : topics) out += (out.empty() ? "" : ", ") + t->name + " (" + t->type + ")";
  return out;
}

std::vector<std::string> SelectedTopics::names() const {
  std::vector<std::string> out;
  for (const TopicInfo* t : {lidar, odometry, ouster_metadata, ground_truth, class_table, imu})
    if (t) out.push_back(t->name);
  return out;
}

SelectedTopics selectTopics(const std::vector<TopicInfo>& topics, const ScanSourceOptions& options,
                            const std::string& where) {
  SelectedTopics s;
  std::vector<const TopicInfo*> lidars, odometries;
  LidarKind kind{};
  for (const auto& t : topics) {
    if (t.serialization != Serialization::Cdr && t.serialization != Serialization::Ros1) continue;  // json, protobuf, …
    if (lidarKindOf(t, kind)) lidars.push_back(&t);
    if (t.type == kOdometryType && t.name != kGroundTruthTopic) odometries.push_back(&t);
  }
  s.lidar = pick(lidars, topics, options.lidar_topic, "LiDAR", "--lidar-topic", true, where);
  lidarKindOf(*s.lidar, s.kind);
  s.odometry = pick(odometries, topics, options.odom_topic, "odometry", "--odom-topic", false, where);
  s.imu = pickImu(topics, s, s.imu_packets);
  for (const auto& t : topics) {
    if (&t == s.lidar || &t == s.odometry || &t == s.imu) continue;
    if (s.kind == LidarKind::OusterPackets && t.type == kStringType && contains(t.name, "metadata") &&
        (!s.ouster_metadata || t.name.rfind(s.lidar->name.substr(0, s.lidar->name.rfind('/')), 0) == 0)) {
      s.ouster_metadata = &t;
    } else if (t.name == kGroundTruthTopic && (t.type == kPoseStampedType || t.type == kOdometryType)) {
      s.ground_truth = &t;
    } else if (t.name == kClassTableTopic && t.type == kStringType) {
      s.class_table = &t;
    } else {
      s.skipped.push_back(t.name + " (" + t.type + "): not read");
    }
  }
  return s;
}

}  // namespace hazmap::sources
