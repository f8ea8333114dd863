// ROS 1 bags (format 2.0): the real Ouster OS-0-128 bag, and bags built here by a small writer
// that follows the format description, in each chunk compression (none, bz2, lz4), indexed
// or not, whole or cut short, with ROS 1-serialized PointCloud2 / Odometry / VelodyneScan /
// PacketMsg / String messages.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstring>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "ros1_bag_builder.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

TEST(Ros1Bag, RealOusterBag) {
  const auto path = test::sharedData("sensors/ouster-os0-128-ros1/512x10_raw.bag");
  ASSERT_TRUE(isBag(path));
  auto reader = openBag(path);
  std::map<std::string, const TopicInfo*> topics;
  for (const auto& t : reader->topics()) topics[t.name] = &t;
  ASSERT_EQ(topics.size(), 3u);
  EXPECT_EQ(topics.at("/os_node0/lidar_packets")->type, "ouster_ros/msg/PacketMsg");
  EXPECT_EQ(topics.at("/os_node0/imu_packets")->type, "ouster_ros/msg/PacketMsg");
  EXPECT_EQ(topics.at("/os_node0/metadata")->type, "std_msgs/msg/String");
  EXPECT_EQ(topics.at("/os_node0/metadata")->definition.find("string data"), 0u);
  for (const auto& [name, t] : topics) EXPECT_EQ(t->serialization, Serialization::Ros1);
  BagMessage m;
  std::map<std::string, std::size_t> counts;
  std::set<std::size_t> lidar_sizes, imu_sizes;
  nlohmann::json metadata;
  std::int64_t last = 0;
  while (reader->next(m)) {
    EXPECT_GE(m.log_time_ns, last);
    last = m.log_time_ns;
    ++counts[m.topic->name];
    if (m.topic->name == "/os_node0/metadata") {
      metadata = nlohmann::json::parse(decodeString(m.data, m.topic->serialization, "metadata"));
    } else {
      const auto packet = decodeOusterPacket(m.data, m.topic->serialization, m.topic->name);
      (m.topic->name == "/os_node0/lidar_packets" ? lidar_sizes : imu_sizes).insert(packet.data.size());
    }
  }
  for (const auto& [name, t] : topics) EXPECT_EQ(counts[name], t->message_count) << name;
  EXPECT_EQ(counts.at("/os_node0/metadata"), 1u);
  // 512 columns in packets of 16 columns: one full scan is at least 32 packets.
  EXPECT_GE(counts.at("/os_node0/lidar_packets"), 32u);
  ASSERT_TRUE(metadata.is_object());
  EXPECT_EQ(metadata.at("beam_intrinsics").at("beam_altitude_angles").size(), 128u);
  EXPECT_EQ(metadata.at("config_params").at("lidar_mode").get<std::string>(), "512x10");
  EXPECT_EQ(metadata.at("sensor_info").at("prod_line").get<std::string>(), "OS-0-128");
  ASSERT_EQ(metadata.at("lidar_data_format").at("udp_profile_lidar").get<std::string>(), "RNG15_RFL8_NIR8");
  // RNG15_RFL8_NIR8 packet: 32-byte header, 16 columns of (12-byte column header + 4 bytes per
  // pixel × 128), 32-byte footer.
  EXPECT_EQ(lidar_sizes, (std::set<std::size_t>{32u + 16u * (12 + 4 * 128) + 32u}));
  EXPECT_EQ(imu_sizes, (std::set<std::size_t>{48u}));
  EXPECT_TRUE(reader->loss().notices.empty());
}

using namespace hazmap::test;

namespace {

const std::vector<Conn> kConns = {{"/points", "sensor_msgs/PointCloud2"}, {"/odom", "nav_msgs/Odometry"},
                                  {"/velodyne_packets", "velodyne_msgs/VelodyneScan"}, {"/os/metadata", "std_msgs/String"},
                                  {"/os/lidar_packets", "ouster_ros/PacketMsg"}};

std::vector<std::vector<Msg>> messages() {
  Ros1Out str, packet;
  str.str("{\"lidar_mode\": \"1024x10\"}");
  packet.bytes(std::vector<std::uint8_t>(300, 9));
  // The second chunk starts earlier than the first one ends: the reader must merge them.
  return {{{0, 10, ros1Cloud(10, 1)}, {1, 11, ros1Odometry(11, 0.5)}, {2, 14, ros1VelodyneScan(14, 3)}},
          {{0, 12, ros1Cloud(12, 2)}, {3, 13, str.b}, {4, 15, packet.b}}};
}

void writeFile(const fs::path& p, const std::vector<std::uint8_t>& b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

void checkBuiltBag(MessageReader& reader) {
  ASSERT_EQ(reader.topics().size(), 5u);
  EXPECT_EQ(reader.topics()[0].type, "sensor_msgs/msg/PointCloud2");
  BagMessage m;
  std::vector<std::int64_t> times;
  while (reader.next(m)) {
    times.push_back(m.log_time_ns);
    EXPECT_EQ(m.topic->serialization, Serialization::Ros1);
    const auto& name = m.topic->name;
    if (name == "/points") {
      const auto cloud = pointCloud2ToCloud(decodePointCloud2(m.data, Serialization::Ros1, name), name);
      ASSERT_EQ(cloud.size(), 2u);
      EXPECT_FLOAT_EQ(cloud.points[1].x(), times.size() == 1 ? 2.0f : 3.0f);
      EXPECT_EQ(cloud.points[1].z(), 6.0f);
    } else if (name == "/odom") {
      const auto o = decodeOdometry(m.data, Serialization::Ros1, name);
      EXPECT_EQ(o.pose.translation().x(), 0.5);
      EXPECT_EQ(o.child_frame_id, "base_link");
      EXPECT_NEAR(o.header.stamp, 11.5, 1e-9);
    } else if (name == "/velodyne_packets") {
      const auto scan = decodeVelodyneScan(m.data, Serialization::Ros1, name);
      ASSERT_EQ(scan.packets.size(), 3u);
      EXPECT_EQ(scan.packets[2].data, std::vector<std::uint8_t>(1206, 2));
      EXPECT_NEAR(scan.packets[1].stamp, 14.000001, 1e-9);
    } else if (name == "/os/metadata") {
      EXPECT_EQ(decodeString(m.data, Serialization::Ros1, name), "{\"lidar_mode\": \"1024x10\"}");
    } else {
      EXPECT_EQ(decodeOusterPacket(m.data, Serialization::Ros1, name).data, std::vector<std::uint8_t>(300, 9));
    }
  }
  const std::vector<std::int64_t> expected = {10'000000000, 11'000000000, 12'000000000, 13'000000000, 14'000000000, 15'000000000};
  EXPECT_EQ(times, expected);
}

}  // namespace

TEST(Ros1Bag, BuiltBagsInEveryCompression) {
  const auto dir = test::scratchDir();
  for (const std::string compression : {"none", "bz2", "lz4"}) {
    for (const bool indexed : {true, false}) {
      SCOPED_TRACE(compression + (indexed ? " indexed" : " unindexed"));
      const auto path = dir / (compression + std::to_string(indexed) + ".bag");
      writeFile(path, buildBag(kConns, messages(), compression, indexed));
      auto reader = openBag(path);
      for (const auto& t : reader->topics()) EXPECT_EQ(t.message_count, t.name == "/points" ? 2u : 1u) << t.name;
      EXPECT_EQ(reader->timeRange(), (std::pair<std::int64_t, std::int64_t>{10'000000000, 15'000000000}));
      checkBuiltBag(*reader);
      EXPECT_TRUE(reader->loss().notices.empty()) << reader->loss().notices.front();
    }
  }
}

TEST(Ros1Bag, TruncatedAndCorruptBags) {
  const auto dir = test::scratchDir();
  // A recorder killed in the second chunk: no index, the first chunk's messages survive.
  auto bag = buildBag(kConns, messages(), "bz2", false);
  const auto full_size = bag.size();
  bag.resize(bag.size() - 50);
  writeFile(dir / "cut.bag", bag);
  auto reader = openBag(dir / "cut.bag");
  BagMessage m;
  std::size_t n = 0;
  while (reader->next(m)) ++n;
  EXPECT_EQ(n, 3u);
  EXPECT_GT(reader->loss().bytes_unread, 0u);
  EXPECT_LT(reader->loss().bytes_unread, full_size);
  ASSERT_EQ(reader->loss().notices.size(), 1u);
  EXPECT_NE(reader->loss().notices[0].find("truncated at offset"), std::string::npos);
  // A bz2 chunk with scribbled data: skipped with its offset, the other chunk read.
  bag = buildBag(kConns, messages(), "bz2", true);
  const std::size_t first_chunk = 13 + 4096;
  for (std::size_t i = 0; i < 16; ++i) bag[first_chunk + 120 + i] ^= 0xFF;
  writeFile(dir / "corrupt.bag", bag);
  reader = openBag(dir / "corrupt.bag");
  n = 0;
  while (reader->next(m)) ++n;
  EXPECT_EQ(n, 3u);
  EXPECT_EQ(reader->loss().chunks_skipped, 1u);
  ASSERT_EQ(reader->loss().notices.size(), 1u);
  EXPECT_NE(reader->loss().notices[0].find("offset " + std::to_string(first_chunk)), std::string::npos) << reader->loss().notices[0];
  // Not a bag at all.
  writeFile(dir / "x.bag", std::vector<std::uint8_t>{'#', 'R', 'O', 'S'});
  EXPECT_THROW(openBag(dir / "x.bag"), Error);
}

TEST(RosMessages, Ros1TruncatedMessagesFail) {
  const auto cloud = ros1Cloud(1, 0);
  for (std::size_t n = 0; n < cloud.size(); n += 5)
    EXPECT_THROW(decodePointCloud2(std::span(cloud).first(n), Serialization::Ros1, "t"), Error);
  const auto scan = ros1VelodyneScan(1, 2);
  EXPECT_THROW(decodeVelodyneScan(std::span(scan).first(scan.size() - 1), Serialization::Ros1, "t"), Error);
}
