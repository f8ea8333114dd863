#include "replay_datagrams.hpp"

#include <deque>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap::cli {

namespace {

class CaptureDatagrams final : public ReplayDatagrams {
 public:
  explicit CaptureDatagrams(const std::filesystem::path& path) : reader_(path) {}
  bool next(ReplayDatagram& d) override {
    UdpPacket p;
    if (!reader_.next(p)) return false;
    d = {p.time_ns, p.destination_port, p.payload};
    return true;
  }

 private:
  PcapReader reader_;
};

enum class PacketTopic { None, Velodyne, Pandar, OusterLidar, OusterImu };

PacketTopic packetTopic(const TopicInfo& t) {
  if (t.type == "velodyne_msgs/msg/VelodyneScan") return PacketTopic::Velodyne;
  if (t.type == "pandar_msgs/msg/PandarScan") return PacketTopic::Pandar;
  if (t.type == "ouster_ros/msg/PacketMsg" || t.type == "ouster_sensor_msgs/msg/PacketMsg")
    return t.name.find("imu") != std::string::npos ? PacketTopic::OusterImu : PacketTopic::OusterLidar;
  return PacketTopic::None;
}

class BagDatagrams final : public ReplayDatagrams {
 public:
  explicit BagDatagrams(const std::filesystem::path& path) : path_(path.string()), bag_(openBag(path)) {
    std::vector<std::string> names;
    for (const TopicInfo& t : bag_->topics())
      if (packetTopic(t) != PacketTopic::None) names.push_back(t.name);
    if (names.empty())
      fail(path_, "has no LiDAR packet topic (VelodyneScan, PandarScan, Ouster packets) to replay");
    bag_->selectTopics(names);
  }

  bool next(ReplayDatagram& d) override {
    while (queue_.empty()) {
      BagMessage m;
      if (!bag_->next(m)) return false;
      unpack(m);
    }
    current_ = std::move(queue_.front());
    queue_.pop_front();
    d = {current_.time_ns, current_.port, current_.bytes};
    return true;
  }

 private:
  struct Held {
    std::int64_t time_ns = 0;
    std::uint16_t port = 0;
    std::vector<std::uint8_t> bytes;
  };

  /// A message's packets, each at its own stamp (the recorder's time when it has none).
  void unpack(const BagMessage& m) {
    const std::string where = path_ + " " + m.topic->name;
    const PacketTopic kind = packetTopic(*m.topic);
    const auto add = [&](LidarPacket& p, std::uint16_t port) {
      const std::int64_t t = p.stamp > 0 ? static_cast<std::int64_t>(p.stamp * 1e9) : m.log_time_ns;
      queue_.push_back({t, port, std::move(p.data)});
    };
    if (kind == PacketTopic::OusterLidar || kind == PacketTopic::OusterImu) {
      LidarPacket p = decodeOusterPacket(m.data, m.topic->serialization, where);
      add(p, kind == PacketTopic::OusterImu ? 7503 : 7502);
      return;
    }
    VelodyneScanMsg scan = kind == PacketTopic::Velodyne ? decodeVelodyneScan(m.data, m.topic->serialization, where)
                                                         : decodePandarScan(m.data, m.topic->serialization, where);
    for (LidarPacket& p : scan.packets) add(p, 2368);
  }

  std::string path_;
  std::unique_ptr<MessageReader> bag_;
  std::deque<Held> queue_;
  Held current_;
};

}  // namespace

std::unique_ptr<ReplayDatagrams> openReplayDatagrams(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) fail(path.string(), "no such file or folder");
  if (isPcap(path)) return std::make_unique<CaptureDatagrams>(path);
  if (isBag(path)) return std::make_unique<BagDatagrams>(path);
  fail(path.string(), "is neither a packet capture (.pcap, .pcapng) nor a bag (.bag, .mcap, rosbag2 folder)");
}

}  // namespace hazmap::cli
