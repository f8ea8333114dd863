// MCAP writer round trips: what hazmap writes (zstd / lz4 / uncompressed chunks, indexes,
// summary) reads back through the reader, indexed and scanned, with the same values.
#include <gtest/gtest.h>

#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/mcap_writer.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

LabeledCloud makeCloud(int k, std::size_t n) {
  LabeledCloud c;
  c.enableIntensity();
  c.enableTimestamps();
  for (std::size_t i = 0; i < n; ++i) {
    const float a = 0.01f * static_cast<float>(i);
    c.push_back({10.0f * std::cos(a) + k, 10.0f * std::sin(a), 0.001f * i}, static_cast<ClassId>(i % 4),
                static_cast<float>(i % 100), 100.0 + k * 0.1 + 1e-5 * i);
  }
  return c;
}

struct Written {
  std::vector<LabeledCloud> clouds;
  std::vector<Eigen::Isometry3d> odometry, truth;
};

Written writeSequence(const fs::path& path, McapWriterOptions options, int frames) {
  McapWriter writer(path, options);
  const auto points = writer.addRosChannel("/points", "sensor_msgs/msg/PointCloud2");
  const auto odom = writer.addRosChannel("/odom", "nav_msgs/msg/Odometry");
  const auto truth = writer.addRosChannel("/ground_truth", "geometry_msgs/msg/PoseStamped");
  const auto image = writer.addRosChannel("/thermal/image_raw", "sensor_msgs/msg/Image");
  Written w;
  for (int k = 0; k < frames; ++k) {
    const double stamp = 100.0 + 0.1 * k;
    const auto t_ns = static_cast<std::int64_t>(std::llround(stamp * 1e9));
    w.clouds.push_back(makeCloud(k, 2000));
    writer.write(points, t_ns, encodePointCloud2(cloudToPointCloud2(w.clouds.back(), {stamp, "lidar"})));
    OdometryMsg o;
    o.header = {stamp, "odom"};
    o.pose = Eigen::Translation3d(0.5 * k, 0.1, 0) * Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitZ());
    w.odometry.push_back(o.pose);
    // Odometry arrives 1 ms *before* the cloud's log time, written after it: out of order.
    writer.write(odom, t_ns - 1000000, encodeOdometry(o));
    w.truth.push_back(Eigen::Translation3d(0.5 * k, 0, 0) * Eigen::Isometry3d::Identity());
    writer.write(truth, t_ns + 1000000, encodePoseStamped({stamp, "map"}, w.truth.back()));
    ImageMsg img;
    img.header = {stamp, "thermal"};
    img.width = 4, img.height = 2, img.encoding = "mono16", img.step = 8;
    img.data.assign(16, static_cast<std::uint8_t>(k));
    writer.write(image, t_ns + 2000000, encodeImage(img));
  }
  writer.close();
  return w;
}

void checkReadBack(const fs::path& path, const Written& w) {
  auto reader = openBag(path);
  ASSERT_EQ(reader->topics().size(), 4u);
  for (const auto& t : reader->topics()) EXPECT_EQ(t.message_count, w.clouds.size()) << t.name;
  EXPECT_EQ(reader->timeRange().first, 99999000000);
  BagMessage m;
  std::size_t clouds = 0, odoms = 0, truths = 0, images = 0;
  std::int64_t last = 0;
  while (reader->next(m)) {
    EXPECT_GE(m.log_time_ns, last);
    last = m.log_time_ns;
    const auto& name = m.topic->name;
    if (name == "/points") {
      EXPECT_EQ(m.topic->type, "sensor_msgs/msg/PointCloud2");
      const auto cloud = pointCloud2ToCloud(decodePointCloud2(m.data, m.topic->serialization, name), name);
      const auto& ref = w.clouds.at(clouds++);
      ASSERT_EQ(cloud.size(), ref.size());
      EXPECT_EQ(cloud.points, ref.points);
      EXPECT_EQ(cloud.classes, ref.classes);
      EXPECT_EQ(cloud.intensity, ref.intensity);
      for (std::size_t i = 0; i < cloud.size(); i += 97) EXPECT_NEAR(cloud.timestamps[i], ref.timestamps[i], 1e-6);
    } else if (name == "/odom") {
      EXPECT_TRUE(decodeOdometry(m.data, m.topic->serialization, name).pose.isApprox(w.odometry.at(odoms++), 1e-12));
    } else if (name == "/ground_truth") {
      EXPECT_TRUE(decodePoseStamped(m.data, m.topic->serialization, name).pose.isApprox(w.truth.at(truths++), 1e-12));
    } else {
      const auto img = decodeImage(m.data, m.topic->serialization, name);
      EXPECT_EQ(img.data, std::vector<std::uint8_t>(16, static_cast<std::uint8_t>(images++)));
    }
  }
  EXPECT_EQ(clouds, w.clouds.size());
  EXPECT_EQ(odoms, w.clouds.size());
  EXPECT_EQ(truths, w.clouds.size());
  EXPECT_EQ(images, w.clouds.size());
  EXPECT_TRUE(reader->loss().notices.empty()) << reader->loss().notices.front();
}

}  // namespace

TEST(McapWriter, RoundTripEveryCompression) {
  const auto dir = test::scratchDir();
  for (const auto compression : {McapCompression::Zstd, McapCompression::Lz4, McapCompression::None}) {
    McapWriterOptions options;
    options.compression = compression;
    options.chunk_size = 50000;  // several chunks, each cloud spanning one
    const auto path = dir / ("seq" + std::to_string(static_cast<int>(compression)) + ".mcap");
    const Written w = writeSequence(path, options, 6);
    checkReadBack(path, w);
    // The same file cut before its summary reads the same through the scan.
    std::ifstream in(path, std::ios::binary);
    std::vector<char> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    const auto cut = path.string() + ".cut.mcap";
    std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 100));
    auto scanned = openBag(cut);
    BagMessage m;
    std::size_t n = 0;
    while (scanned->next(m)) ++n;
    EXPECT_EQ(n, 24u);  // the scan stops at the Data End record, before the cut
    EXPECT_TRUE(scanned->loss().notices.empty());
  }
}

TEST(McapWriter, NothingLeftWithoutClose) {
  const auto dir = test::scratchDir();
  {
    McapWriter writer(dir / "partial.mcap");
    const auto ch = writer.addRosChannel("/s", "std_msgs/msg/String");
    writer.write(ch, 1, encodeString("x"));
    EXPECT_THROW(writer.write(7, 1, encodeString("x")), Error);
    EXPECT_THROW(writer.addRosChannel("/u", "unknown_msgs/msg/Thing"), Error);
  }
  EXPECT_FALSE(fs::exists(dir / "partial.mcap"));
  EXPECT_TRUE(fs::is_empty(dir));
}
