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
#include "sources/bag_readers.hpp"
#include "sources/compression.hpp"
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

namespace {

/// ROS 1 serialization: little-endian, unaligned, strings and arrays with a u32 count.
struct Ros1Out {
  std::vector<std::uint8_t> b;
  template <class T>
  void put(T v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof v);
    std::memcpy(b.data() + at, &v, sizeof v);
  }
  void str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    b.insert(b.end(), s.begin(), s.end());
  }
  void bytes(const std::vector<std::uint8_t>& d, bool with_count = true) {
    if (with_count) put<std::uint32_t>(static_cast<std::uint32_t>(d.size()));
    b.insert(b.end(), d.begin(), d.end());
  }
  void header(std::uint32_t sec, const std::string& frame) {
    put<std::uint32_t>(7);  // seq
    put<std::uint32_t>(sec);
    put<std::uint32_t>(500000000);
    str(frame);
  }
};

std::vector<std::uint8_t> ros1Cloud(std::uint32_t sec, float x0) {
  Ros1Out o;
  o.header(sec, "velodyne");
  o.put<std::uint32_t>(1), o.put<std::uint32_t>(2);  // height, width
  o.put<std::uint32_t>(3);
  for (const auto& [name, off] : {std::pair{"x", 0u}, {"y", 4u}, {"z", 8u}}) {
    o.str(name), o.put<std::uint32_t>(off), o.put<std::uint8_t>(7), o.put<std::uint32_t>(1);
  }
  o.put<std::uint8_t>(0), o.put<std::uint32_t>(12), o.put<std::uint32_t>(24);
  std::vector<std::uint8_t> data(24);
  const float xyz[6] = {x0, 2, 3, x0 + 1, 5, 6};
  std::memcpy(data.data(), xyz, 24);
  o.bytes(data);
  o.put<std::uint8_t>(1);
  return o.b;
}

std::vector<std::uint8_t> ros1Odometry(std::uint32_t sec, double x) {
  Ros1Out o;
  o.header(sec, "odom");
  o.str("base_link");
  for (const double v : {x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}) o.put(v);
  for (int i = 0; i < 36 + 6 + 36; ++i) o.put(0.0);
  return o.b;
}

std::vector<std::uint8_t> ros1VelodyneScan(std::uint32_t sec, int packets) {
  Ros1Out o;
  o.header(sec, "velodyne");
  o.put<std::uint32_t>(static_cast<std::uint32_t>(packets));
  for (int p = 0; p < packets; ++p) {
    o.put<std::uint32_t>(sec), o.put<std::uint32_t>(1000u * p);
    o.bytes(std::vector<std::uint8_t>(1206, static_cast<std::uint8_t>(p)), false);
  }
  return o.b;
}

/// One record: header fields, data.
std::vector<std::uint8_t> record(const std::vector<std::pair<std::string, std::vector<std::uint8_t>>>& fields,
                                 const std::vector<std::uint8_t>& data) {
  Ros1Out h;
  for (const auto& [name, value] : fields) {
    h.put<std::uint32_t>(static_cast<std::uint32_t>(name.size() + 1 + value.size()));
    h.b.insert(h.b.end(), name.begin(), name.end());
    h.b.push_back('=');
    h.b.insert(h.b.end(), value.begin(), value.end());
  }
  Ros1Out r;
  r.bytes(h.b);
  r.bytes(data);
  return r.b;
}
template <class T>
std::vector<std::uint8_t> le(T v) {
  std::vector<std::uint8_t> b(sizeof v);
  std::memcpy(b.data(), &v, sizeof v);
  return b;
}
std::vector<std::uint8_t> text(const std::string& s) { return {s.begin(), s.end()}; }

struct Msg {
  std::uint32_t conn;
  std::uint32_t sec;
  std::vector<std::uint8_t> data;
};
struct Conn {
  std::string topic, type;
};

std::vector<std::uint8_t> connectionRecord(std::uint32_t id, const Conn& c) {
  const auto info = record({{"topic", text(c.topic)}, {"type", text(c.type)}, {"md5sum", text("0123456789abcdef0123456789abcdef")},
                            {"message_definition", text("# test\n")}}, {});
  // The connection's data is its header fields alone (no trailing data length).
  std::uint32_t hlen;
  std::memcpy(&hlen, info.data(), 4);
  return record({{"op", {0x07}}, {"conn", le(id)}, {"topic", text(c.topic)}},
                std::vector<std::uint8_t>(info.begin() + 4, info.begin() + 4 + hlen));
}

/// A bag of `chunks` chunks in `compression`, with or without its index section.
std::vector<std::uint8_t> buildBag(const std::vector<Conn>& conns, const std::vector<std::vector<Msg>>& chunks,
                                   const std::string& compression, bool indexed) {
  std::vector<std::uint8_t> bag(sources::kRos1Magic, sources::kRos1Magic + 13);
  const std::size_t header_at = bag.size();
  std::vector<std::uint8_t> chunk_infos;
  for (const auto& msgs : chunks) {
    std::vector<std::uint8_t> inner;
    std::set<std::uint32_t> declared;
    std::map<std::uint32_t, std::uint32_t> per_conn;
    std::uint32_t t0 = UINT32_MAX, t1 = 0;
    for (const auto& m : msgs) {
      if (declared.insert(m.conn).second) {
        const auto c = connectionRecord(m.conn, conns[m.conn]);
        inner.insert(inner.end(), c.begin(), c.end());
      }
      const auto r = record({{"op", {0x02}}, {"conn", le(m.conn)}, {"time", le(std::uint64_t{m.sec})}}, m.data);
      inner.insert(inner.end(), r.begin(), r.end());
      ++per_conn[m.conn], t0 = std::min(t0, m.sec), t1 = std::max(t1, m.sec);
    }
    std::vector<std::uint8_t> stored = inner;
    if (compression == "bz2") stored = sources::compressBz2(inner);
    if (compression == "lz4") stored = sources::compressLz4Frame(inner);
    const std::uint64_t chunk_pos = bag.size() + 4096 * (bag.size() == header_at);
    const auto chunk = record({{"op", {0x05}}, {"compression", text(compression)}, {"size", le(static_cast<std::uint32_t>(inner.size()))}}, stored);
    std::vector<std::uint8_t> counts;
    for (const auto& [c, n] : per_conn) {
      const auto a = le(c), b = le(n);
      counts.insert(counts.end(), a.begin(), a.end());
      counts.insert(counts.end(), b.begin(), b.end());
    }
    const auto info = record({{"op", {0x06}}, {"ver", le(1u)}, {"chunk_pos", le(chunk_pos)}, {"start_time", le(std::uint64_t{t0})},
                              {"end_time", le(std::uint64_t{t1})}, {"count", le(static_cast<std::uint32_t>(per_conn.size()))}}, counts);
    chunk_infos.insert(chunk_infos.end(), info.begin(), info.end());
    if (bag.size() == header_at) bag.resize(header_at + 4096, ' ');  // room for the bag header
    bag.insert(bag.end(), chunk.begin(), chunk.end());
  }
  if (bag.size() == header_at) bag.resize(header_at + 4096, ' ');
  const std::uint64_t index_pos = indexed ? bag.size() : 0;
  if (indexed) {
    for (std::uint32_t i = 0; i < conns.size(); ++i) {
      const auto c = connectionRecord(i, conns[i]);
      bag.insert(bag.end(), c.begin(), c.end());
    }
    bag.insert(bag.end(), chunk_infos.begin(), chunk_infos.end());
  }
  auto header = record({{"op", {0x03}}, {"index_pos", le(index_pos)}, {"conn_count", le(static_cast<std::uint32_t>(conns.size()))},
                        {"chunk_count", le(static_cast<std::uint32_t>(chunks.size()))}}, {});
  const std::size_t pad = 4096 - header.size();
  header = record({{"op", {0x03}}, {"index_pos", le(index_pos)}, {"conn_count", le(static_cast<std::uint32_t>(conns.size()))},
                   {"chunk_count", le(static_cast<std::uint32_t>(chunks.size()))}}, std::vector<std::uint8_t>(pad, ' '));
  std::copy(header.begin(), header.end(), bag.begin() + static_cast<std::ptrdiff_t>(header_at));
  return bag;
}

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
