// rosbag2 (sqlite3) folders on the real nebula recordings, and the CDR / ROS 1 message
// decoders: the real 64,000-point PointCloud2 and PointCloud2 layouts of every kind.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <fstream>

#include "sources/bag_readers.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

std::vector<std::uint8_t> readBytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct VelodyneBag {
  const char* folder;
  const char* topic;
  std::size_t messages;
  std::uint8_t factory_model;  // byte 1205 of every packet
};

void checkVelodyneBag(const VelodyneBag& bag) {
  SCOPED_TRACE(bag.folder);
  const auto path = test::sharedData(std::string("sensors/") + bag.folder);
  ASSERT_TRUE(isBag(path));
  auto reader = openBag(path);
  ASSERT_EQ(reader->topics().size(), 1u);
  const TopicInfo& topic = reader->topics()[0];
  EXPECT_EQ(topic.name, bag.topic);
  EXPECT_EQ(topic.type, "velodyne_msgs/msg/VelodyneScan");
  EXPECT_EQ(topic.serialization, Serialization::Cdr);
  EXPECT_EQ(topic.message_count, bag.messages);
  const auto [t0, t1] = reader->timeRange();
  EXPECT_GT(t1, t0);
  BagMessage m;
  std::size_t n = 0, packets = 0;
  std::int64_t last = 0;
  while (reader->next(m)) {
    ++n;
    EXPECT_EQ(m.topic, &topic);
    EXPECT_GE(m.log_time_ns, last);
    EXPECT_GE(m.log_time_ns, t0);
    EXPECT_LE(m.log_time_ns, t1);
    last = m.log_time_ns;
    const auto scan = decodeVelodyneScan(m.data, m.topic->serialization, "vlp");
    EXPECT_GT(scan.packets.size(), 10u);
    // Nothing left over: the message is header + count + packets of 8 + 1206 bytes (+2 padding).
    EXPECT_LT(m.data.size() - scan.packets.size() * 1216, 64u);
    packets += scan.packets.size();
    double prev = 0.0;
    for (const auto& p : scan.packets) {
      ASSERT_EQ(p.data.size(), 1206u);
      // Every data block starts with the 0xFFEE (or 0xFFDD.. upper-block) flag; the factory
      // bytes close the packet. Both only line up if the CDR alignment between packets is right.
      EXPECT_EQ(p.data[0], 0xFF);
      EXPECT_EQ(p.data[1205], bag.factory_model);
      EXPECT_GE(p.stamp, prev);
      prev = p.stamp;
    }
    EXPECT_NEAR(scan.header.stamp, m.log_time_ns * 1e-9, 1.0);
  }
  EXPECT_EQ(n, bag.messages);
  EXPECT_TRUE(reader->loss().notices.empty());
  std::printf("%s: %zu messages, %zu packets\n", bag.folder, n, packets);
}

}  // namespace

TEST(Rosbag2, VelodyneVlp16) { checkVelodyneBag({"velodyne-vlp16", "/velodyne_packets", 4, 0x22}); }
TEST(Rosbag2, VelodyneVlp32) { checkVelodyneBag({"velodyne-vlp32", "/sensing/lidar/front/velodyne_packets", 5, 0x28}); }
TEST(Rosbag2, VelodyneVls128) { checkVelodyneBag({"velodyne-vls128", "/velodyne_packets", 4, 0xA1}); }

TEST(Rosbag2, Vlp16PacketCountsPerMessage) {
  auto reader = openBag(test::sharedData("sensors/velodyne-vlp16/metadata.yaml"));
  BagMessage m;
  std::vector<std::size_t> counts;
  while (reader->next(m)) counts.push_back(decodeVelodyneScan(m.data, Serialization::Cdr, "vlp16").packets.size());
  ASSERT_EQ(counts.size(), 4u);
  // The README: ~151 packets per message (a dual-return VLP-16 sends 1508 packets/s, 10 Hz).
  for (const auto c : counts) EXPECT_NEAR(static_cast<double>(c), 151.0, 2.0);
  EXPECT_EQ(counts[0] + counts[1] + counts[2] + counts[3], 603u);
}

TEST(Rosbag2, SelectTopicsAndErrors) {
  auto reader = openBag(test::sharedData("sensors/velodyne-vlp16"));
  reader->selectTopics({"/nothing"});
  BagMessage m;
  EXPECT_FALSE(reader->next(m));
  const auto dir = test::scratchDir();
  EXPECT_FALSE(isBag(dir));
  EXPECT_THROW(openBag(dir / "missing"), Error);
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                                          "  relative_file_paths: [gone_0.db3]\n";
  try {
    openBag(dir);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("gone_0.db3"), std::string::npos) << e.what();
  }
  std::ofstream(dir / "bad.db3") << "SQLite format 3 but not really";
  EXPECT_THROW(sources::openDb3(dir / "bad.db3"), Error);
}

TEST(Rosbag2, SplitBagIsMergedInTimeOrder) {
  // Two copies of the VLP-16 storage file as a split bag: every message twice, in time order.
  const auto dir = test::scratchDir();
  const auto src = test::sharedData("sensors/velodyne-vlp16/1673400471837873222_0.db3");
  std::filesystem::copy_file(src, dir / "a_0.db3");
  std::filesystem::copy_file(src, dir / "a_1.db3");
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                                          "  relative_file_paths:\n    - a_0.db3\n    - a_1.db3\n";
  auto reader = openBag(dir);
  ASSERT_EQ(reader->topics().size(), 1u);
  EXPECT_EQ(reader->topics()[0].message_count, 8u);
  BagMessage m;
  std::vector<std::int64_t> times;
  while (reader->next(m)) {
    EXPECT_EQ(m.topic, &reader->topics()[0]);
    times.push_back(m.log_time_ns);
  }
  ASSERT_EQ(times.size(), 8u);
  EXPECT_TRUE(std::is_sorted(times.begin(), times.end()));
  EXPECT_EQ(times[0], times[1]);
}

TEST(RosMessages, RealPointCloud2Cdr) {
  const auto bytes = readBytes(test::sharedData("sensors/pointcloud2-cdr/pointcloud2_64000_points.cdr"));
  const auto msg = decodePointCloud2(bytes, Serialization::Cdr, "cloudini");
  EXPECT_EQ(msg.header.frame_id, "lidar_link");
  EXPECT_EQ(std::uint64_t{msg.width} * msg.height, 64000u);
  EXPECT_EQ(msg.point_step, 26u);
  ASSERT_EQ(msg.fields.size(), 6u);
  const char* names[] = {"x", "y", "z", "intensity", "ring", "timestamp"};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(msg.fields[i].name, names[i]);
  EXPECT_EQ(msg.data.size(), 64000u * 26u);
  const auto cloud = pointCloud2ToCloud(msg, "cloudini");
  EXPECT_GT(cloud.size(), 30000u);
  EXPECT_LE(cloud.size(), 64000u);
  ASSERT_TRUE(cloud.hasTimestamps());
  ASSERT_TRUE(cloud.hasIntensity());
  const auto [lo, hi] = std::minmax_element(cloud.timestamps.begin(), cloud.timestamps.end());
  EXPECT_NEAR(*lo, msg.header.stamp, 0.2);  // one rotation around the stamp, in absolute seconds
  EXPECT_LT(*hi - *lo, 0.2);
  for (const auto& p : cloud.points) ASSERT_LT(p.norm(), 300.0f);
  // Re-encoding the decoded message gives the file back byte for byte.
  EXPECT_EQ(encodePointCloud2(msg), bytes);
}

namespace {

/// A PointCloud2 with one field of each datatype, padding between fields and after the last,
/// `height` rows with row padding, in the requested endianness.
PointCloud2 everyDatatypeCloud(bool big_endian, std::uint32_t height) {
  PointCloud2 msg;
  msg.header = {1700000000.5, "lidar"};
  msg.height = height;
  msg.width = 3;
  msg.is_bigendian = big_endian;
  // x float64 @0, y float32 @8, z int16 @14 (pad 12-13), intensity uint8 @17 (pad 16),
  // t uint32 ns @20, ring int8 @24, label uint16 @26, i32 @28, u16 @32, i8.. step 40
  msg.fields = {{"x", 0, 8, 1},     {"y", 8, 7, 1},   {"z", 14, 3, 1},     {"intensity", 17, 2, 1},
                {"t", 20, 6, 1},    {"ring", 24, 1, 1}, {"label", 26, 4, 1}, {"other_i32", 28, 5, 1}};
  msg.point_step = 40;
  msg.row_step = msg.width * msg.point_step + 8;
  msg.data.assign(std::size_t{msg.row_step} * height, 0xAB);
  auto put = [&](std::size_t at, auto v) {
    std::uint8_t b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    if (big_endian != (std::endian::native == std::endian::big)) std::reverse(b, b + sizeof v);
    std::memcpy(msg.data.data() + at, b, sizeof v);
  };
  for (std::uint32_t r = 0; r < height; ++r)
    for (std::uint32_t c = 0; c < msg.width; ++c) {
      const std::size_t o = r * msg.row_step + c * msg.point_step;
      const int k = static_cast<int>(r * msg.width + c);
      put(o + 0, 1.25 + k);
      put(o + 8, -2.5f * (k + 1));
      put(o + 14, static_cast<std::int16_t>(-300 + k));
      put(o + 17, static_cast<std::uint8_t>(200 + k));
      put(o + 20, static_cast<std::uint32_t>(1000000u * k));
      put(o + 24, static_cast<std::int8_t>(-k));
      put(o + 26, static_cast<std::uint16_t>(40 + k));
      put(o + 28, static_cast<std::int32_t>(-7));
    }
  return msg;
}

}  // namespace

TEST(RosMessages, PointCloud2AnyLayoutBothEndiannesses) {
  for (const bool big : {false, true}) {
    for (const std::uint32_t height : {1u, 4u}) {
      SCOPED_TRACE(std::to_string(big) + "/" + std::to_string(height));
      const PointCloud2 msg = everyDatatypeCloud(big, height);
      for (const bool cdr_big : {false, true}) {
        const auto decoded = decodePointCloud2(encodePointCloud2(msg, cdr_big), Serialization::Cdr, "t");
        ASSERT_EQ(decoded.data, msg.data);
        ASSERT_EQ(decoded.fields.size(), msg.fields.size());
        EXPECT_EQ(decoded.fields[3].name, "intensity");
        EXPECT_EQ(decoded.fields[3].offset, 17u);
        EXPECT_EQ(decoded.header.frame_id, "lidar");
        EXPECT_NEAR(decoded.header.stamp, 1700000000.5, 1e-6);
        const auto cloud = pointCloud2ToCloud(decoded, "t");
        ASSERT_EQ(cloud.size(), 3u * height);
        for (std::size_t k = 0; k < cloud.size(); ++k) {
          EXPECT_FLOAT_EQ(cloud.points[k].x(), 1.25f + k);
          EXPECT_FLOAT_EQ(cloud.points[k].y(), -2.5f * (k + 1));
          EXPECT_FLOAT_EQ(cloud.points[k].z(), -300.0f + k);
          EXPECT_FLOAT_EQ(cloud.intensity[k], 200.0f + k);
          EXPECT_EQ(cloud.classes[k], 40 + k);
          // uint32 relative nanoseconds → absolute seconds.
          EXPECT_NEAR(cloud.timestamps[k], 1700000000.5 + 1e-3 * k, 1e-6);
        }
      }
    }
  }
}

TEST(RosMessages, PointCloud2TimeConventions) {
  // float32 seconds relative, float64 absolute seconds, float64 absolute nanoseconds.
  struct Case {
    std::uint8_t type;
    double value;
    double expected;
  };
  const double stamp = 1600000000.0;
  for (const Case c : {Case{7, 0.05, stamp + 0.05}, Case{8, stamp + 0.07, stamp + 0.07},
                       Case{8, (stamp + 0.02) * 1e9, stamp + 0.02}, Case{6, 3e7, stamp + 0.03}}) {
    PointCloud2 msg;
    msg.header.stamp = stamp;
    msg.height = 1, msg.width = 1, msg.point_step = 24, msg.row_step = 24;
    msg.fields = {{"x", 0, 7, 1}, {"y", 4, 7, 1}, {"z", 8, 7, 1}, {"time", 16, c.type, 1}};
    msg.data.assign(24, 0);
    const float one = 1.0f;
    std::memcpy(msg.data.data(), &one, 4);
    if (c.type == 7) {
      const float v = static_cast<float>(c.value);
      std::memcpy(msg.data.data() + 16, &v, 4);
    } else if (c.type == 6) {
      const auto v = static_cast<std::uint32_t>(c.value);
      std::memcpy(msg.data.data() + 16, &v, 4);
    } else {
      std::memcpy(msg.data.data() + 16, &c.value, 8);
    }
    const auto cloud = pointCloud2ToCloud(msg, "t");
    ASSERT_EQ(cloud.size(), 1u);
    EXPECT_NEAR(cloud.timestamps[0], c.expected, 1e-5) << int(c.type);
  }
}

TEST(RosMessages, PointCloud2BadLayoutsFailWithOneLine) {
  PointCloud2 msg = everyDatatypeCloud(false, 2);
  auto expectFail = [](const PointCloud2& m, const char* needle) {
    try {
      pointCloud2ToCloud(m, "bag.mcap:/points");
      FAIL() << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find("bag.mcap:/points"), 0u);
    }
  };
  PointCloud2 short_data = msg;
  short_data.data.resize(short_data.data.size() - 9);
  expectFail(short_data, "data bytes");
  PointCloud2 outside = msg;
  outside.fields[0].offset = 36;
  expectFail(outside, "does not fit");
  PointCloud2 unknown = msg;
  unknown.fields[1].datatype = 9;
  expectFail(unknown, "unknown datatype");
  PointCloud2 no_z = msg;
  no_z.fields.erase(no_z.fields.begin() + 2);
  expectFail(no_z, "x, y, z");
  // Truncated serialized messages: every prefix fails cleanly.
  const auto bytes = encodePointCloud2(msg);
  for (std::size_t n = 0; n < bytes.size(); n += 7)
    EXPECT_THROW(decodePointCloud2(std::span(bytes).first(n), Serialization::Cdr, "t"), Error);
}

TEST(RosMessages, OdometryImageStringRoundTrip) {
  OdometryMsg odom;
  odom.header = {12.25, "odom"};
  odom.child_frame_id = "base_link";
  odom.pose = Eigen::Translation3d(1, 2, 3) * Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ());
  odom.pose_covariance.diagonal().setConstant(0.01);
  const auto o = decodeOdometry(encodeOdometry(odom), Serialization::Cdr, "t");
  EXPECT_EQ(o.child_frame_id, "base_link");
  EXPECT_TRUE(o.pose.isApprox(odom.pose, 1e-12));
  EXPECT_EQ(o.pose_covariance, odom.pose_covariance);
  ImageMsg img;
  img.header = {3.0, "thermal"};
  img.height = 2, img.width = 3, img.encoding = "mono16", img.step = 6;
  img.data = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
  const auto i = decodeImage(encodeImage(img, true), Serialization::Cdr, "t");
  EXPECT_EQ(i.encoding, "mono16");
  EXPECT_EQ(i.data, img.data);
  EXPECT_EQ(i.step, 6u);
  img.step = 7;  // rows longer than the data
  EXPECT_THROW(decodeImage(encodeImage(img), Serialization::Cdr, "t"), Error);
  EXPECT_EQ(decodeString(encodeString("{\"a\": 1}"), Serialization::Cdr, "t"), "{\"a\": 1}");
  const auto ps = decodePoseStamped(encodePoseStamped({5.0, "map"}, odom.pose), Serialization::Cdr, "t");
  EXPECT_TRUE(ps.pose.isApprox(odom.pose, 1e-12));
  EXPECT_EQ(ps.header.frame_id, "map");
}

TEST(RosMessages, CloudToPointCloud2RoundTrip) {
  LabeledCloud cloud;
  cloud.enableIntensity();
  cloud.enableTimestamps();
  cloud.push_back({1, 2, 3}, 5, 0.5f, 100.01);
  cloud.push_back({-4, 5, 6}, 7, 0.25f, 100.02);
  const auto msg = cloudToPointCloud2(cloud, {100.0, "velodyne"});
  const auto back = pointCloud2ToCloud(decodePointCloud2(encodePointCloud2(msg), Serialization::Cdr, "t"), "t");
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back.points, cloud.points);
  EXPECT_EQ(back.classes, cloud.classes);
  EXPECT_EQ(back.intensity, cloud.intensity);
  EXPECT_NEAR(back.timestamps[1], 100.02, 1e-6);
}

#include <sqlite3.h>
#include <zstd.h>

TEST(Rosbag2, ZstdPerMessageCompression) {
  // rosbag2's "compression_mode: MESSAGE": each blob is a zstd frame. Compress the VLP-16
  // bag's blobs in a copy and read it back: the same messages, byte for byte.
  const auto dir = test::scratchDir();
  const auto src = test::sharedData("sensors/velodyne-vlp16/1673400471837873222_0.db3");
  std::filesystem::copy_file(src, dir / "z_0.db3");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((dir / "z_0.db3").c_str(), &db), SQLITE_OK);
  std::vector<std::pair<std::int64_t, std::vector<std::uint8_t>>> rows;
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(db, "SELECT id, data FROM messages", -1, &st, nullptr);
  while (sqlite3_step(st) == SQLITE_ROW) {
    const auto* b = static_cast<const std::uint8_t*>(sqlite3_column_blob(st, 1));
    rows.emplace_back(sqlite3_column_int64(st, 0), std::vector<std::uint8_t>(b, b + sqlite3_column_bytes(st, 1)));
  }
  sqlite3_finalize(st);
  sqlite3_prepare_v2(db, "UPDATE messages SET data = ? WHERE id = ?", -1, &st, nullptr);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    std::vector<std::uint8_t> z(ZSTD_compressBound(rows[i].second.size()));
    z.resize(ZSTD_compress(z.data(), z.size(), rows[i].second.data(), rows[i].second.size(), 3));
    if (i == 2) z[z.size() / 2] ^= 0xFF, z[z.size() / 2 + 1] ^= 0xFF;  // one damaged message
    sqlite3_bind_blob(st, 1, z.data(), static_cast<int>(z.size()), SQLITE_TRANSIENT);
    sqlite3_bind_int64(st, 2, rows[i].first);
    ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
    sqlite3_reset(st);
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n"
                                          "  relative_file_paths:\n    - z_0.db3\n  compression_format: zstd\n"
                                          "  compression_mode: MESSAGE\n";
  auto reader = openBag(dir);
  auto plain = openBag(test::sharedData("sensors/velodyne-vlp16"));
  BagMessage a, b;
  std::size_t n = 0;
  while (reader->next(a)) {
    ASSERT_TRUE(plain->next(b));
    if (n == 2) ASSERT_TRUE(plain->next(b));  // the damaged one is skipped
    EXPECT_TRUE(std::equal(a.data.begin(), a.data.end(), b.data.begin(), b.data.end()));
    ++n;
  }
  EXPECT_EQ(n, 3u);
  ASSERT_EQ(reader->loss().notices.size(), 1u);
  EXPECT_NE(reader->loss().notices[0].find("message skipped"), std::string::npos) << reader->loss().notices[0];
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  storage_identifier: sqlite3\n"
                                          "  relative_file_paths: [z_0.db3.zstd]\n  compression_format: zstd\n"
                                          "  compression_mode: FILE\n";
  EXPECT_THROW(openBag(dir), Error);
}

TEST(Rosbag2, TruncatedDb3ReadsWhatSqliteCanStillReach) {
  // A .db3 cut short (disk full, a copy interrupted): sqlite refuses a file shorter than its
  // header's page count outright (one line naming the file); a damage sqlite only meets while
  // stepping ends the stream with a notice. Either way nothing is read silently wrong.
  const auto dir = test::scratchDir();
  const auto src = test::sharedData("sensors/velodyne-vlp16/1673400471837873222_0.db3");
  const auto full = std::filesystem::file_size(src);
  std::filesystem::copy_file(src, dir / "cut_0.db3");
  std::filesystem::resize_file(dir / "cut_0.db3", full * 6 / 10);
  try {
    auto reader = openBag(dir / "cut_0.db3");
    BagMessage m;
    std::size_t n = 0;
    while (reader->next(m)) {
      EXPECT_NO_THROW(decodeVelodyneScan(m.data, Serialization::Cdr, "cut"));
      ++n;
    }
    EXPECT_LT(n, 4u);
    ASSERT_EQ(reader->loss().notices.size(), 1u);
    EXPECT_NE(reader->loss().notices[0].find("cut_0.db3"), std::string::npos) << reader->loss().notices[0];
    std::printf("truncated db3: %zu messages, notice: %s\n", n, reader->loss().notices[0].c_str());
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cut_0.db3"), std::string::npos) << e.what();
    std::printf("truncated db3: %s\n", e.what());
  }
}
