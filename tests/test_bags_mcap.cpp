// The MCAP reader on the three bags written by the format's reference writer (expected.json
// says what each holds), and on damaged copies of them: a corrupt chunk is reported with its
// offset and skipped, a truncated file reads up to its last complete record.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <stdexcept>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

/// The file's bytes; throws naming the file when it cannot be read or is empty (the tests below
/// index into it: an empty read must stop the test, not crash it).
std::vector<std::uint8_t> readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<std::uint8_t> bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (!in.good() && !in.eof()) throw std::runtime_error("cannot read " + p.string());
  if (bytes.empty()) throw std::runtime_error(p.string() + " is empty or missing");
  return bytes;
}
void writeBytes(const fs::path& p, std::span<const std::uint8_t> b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}
nlohmann::json expected() {
  std::ifstream in(test::sharedData("sensors/mcap/expected.json"));
  return nlohmann::json::parse(in);
}
fs::path fixture(const std::string& name) { return test::sharedData("sensors/mcap/" + name); }

struct TopRecord {
  std::uint8_t opcode;
  std::uint64_t offset, length;
};
/// The top-level records of an MCAP file (independent of the reader under test).
std::vector<TopRecord> topRecords(const std::vector<std::uint8_t>& b) {
  std::vector<TopRecord> out;
  std::uint64_t at = 8;
  while (at + 9 <= b.size()) {
    std::uint64_t len;
    std::memcpy(&len, b.data() + at + 1, 8);
    if (at + 9 + len > b.size()) break;
    out.push_back({b[at], at, len});
    at += 9 + len;
  }
  return out;
}

struct ReadAll {
  std::map<std::string, int> counts;
  std::vector<std::pair<std::int64_t, LabeledCloud>> clouds;
  std::vector<std::pair<std::int64_t, OdometryMsg>> odometry;
  std::vector<ImageMsg> images;
  std::vector<std::uint8_t> points_raw;
  std::vector<std::int64_t> times;
};

ReadAll readAll(MessageReader& reader) {
  ReadAll r;
  BagMessage m;
  while (reader.next(m)) {
    const std::string where = m.topic->name;
    ++r.counts[m.topic->name];
    r.times.push_back(m.log_time_ns);
    if (m.topic->name == "/velodyne_points")
      r.clouds.emplace_back(m.log_time_ns, pointCloud2ToCloud(decodePointCloud2(m.data, m.topic->serialization, where), where));
    if (m.topic->name == "/odom") r.odometry.emplace_back(m.log_time_ns, decodeOdometry(m.data, m.topic->serialization, where));
    if (m.topic->name == "/thermal/image_raw") r.images.push_back(decodeImage(m.data, m.topic->serialization, where));
    if (m.topic->name == "/points_raw") r.points_raw.assign(m.data.begin(), m.data.end());
  }
  return r;
}

void checkAgainstExpected(const std::string& name, const ReadAll& r) {
  SCOPED_TRACE(name);
  const auto e = expected()["bags"][name];
  for (const auto& [topic, count] : e["topics"].items()) EXPECT_EQ(r.counts.at(topic), count.get<int>()) << topic;
  EXPECT_TRUE(std::is_sorted(r.times.begin(), r.times.end()));
  ASSERT_EQ(r.clouds.size(), e["clouds"].size());
  for (std::size_t i = 0; i < r.clouds.size(); ++i) {
    const auto& ec = e["clouds"][i];
    const auto& [t, cloud] = r.clouds[i];
    EXPECT_EQ(std::to_string(t), ec["log_time_ns"].get<std::string>());
    ASSERT_EQ(cloud.size(), ec["points"].get<std::size_t>());
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(cloud.points[0][k], ec["first_xyz"][k].get<double>(), 1e-6);
    double sum_x = 0.0;
    for (const auto& p : cloud.points) sum_x += p.x();
    EXPECT_NEAR(sum_x, ec["sum_x"].get<double>(), 0.05);  // float32 storage of 14,831 points
    // Per-point time: both layouts (float s, uint32 ns) → absolute seconds within the scan.
    ASSERT_TRUE(cloud.hasTimestamps());
    const auto [lo, hi] = std::minmax_element(cloud.timestamps.begin(), cloud.timestamps.end());
    // The writer stamped each header with log_time mod 1000 s; t is relative to the first point.
    EXPECT_NEAR(*lo, static_cast<double>(t % 1000000000000) * 1e-9, 1e-6);
    EXPECT_GT(*hi - *lo, 1e-3);
    EXPECT_LT(*hi - *lo, 0.2);
  }
  ASSERT_EQ(r.odometry.size(), e["odometry"].size());
  for (std::size_t i = 0; i < r.odometry.size(); ++i) {
    const auto& eo = e["odometry"][i];
    EXPECT_EQ(std::to_string(r.odometry[i].first), eo["log_time_ns"].get<std::string>());
    const auto& pose = r.odometry[i].second.pose;
    EXPECT_NEAR(pose.translation().x(), eo["x"].get<double>(), 1e-12);
    const Eigen::Vector3d fwd = pose.linear() * Eigen::Vector3d::UnitX();
    EXPECT_NEAR(std::atan2(fwd.y(), fwd.x()), eo["yaw"].get<double>(), 1e-12);
  }
  ASSERT_EQ(r.images.size(), 3u);
  for (const auto& img : r.images) {
    ASSERT_EQ(img.width, 16u);
    ASSERT_EQ(img.height, 12u);
    EXPECT_EQ(img.encoding, "mono16");
    for (std::uint32_t v = 0; v < 12; ++v)
      for (std::uint32_t u = 0; u < 16; ++u) {
        const std::uint16_t px = static_cast<std::uint16_t>(img.data[v * img.step + 2 * u] | img.data[v * img.step + 2 * u + 1] << 8);
        const bool spot = u >= 6 && u < 9 && v >= 4 && v < 7;
        ASSERT_EQ(px, spot ? 35000 : 30000) << u << "," << v;
      }
  }
  EXPECT_EQ(r.points_raw, readBytes(test::sharedData("sensors/pointcloud2-cdr/pointcloud2_64000_points.cdr")));
}

}  // namespace

TEST(Mcap, ReferenceWriterBags) {
  for (const std::string name : {"velodyne-zstd-chunked.mcap", "ouster-lz4-chunked.mcap", "velodyne-unchunked-no-index.mcap"}) {
    ASSERT_TRUE(isBag(fixture(name)));
    auto reader = openBag(fixture(name));
    ASSERT_EQ(reader->topics().size(), 4u);
    for (const auto& t : reader->topics()) {
      EXPECT_EQ(t.serialization, Serialization::Cdr);
      EXPECT_NE(t.definition.find("std_msgs/Header header"), std::string::npos) << t.name;
      EXPECT_EQ(t.message_count, expected()["bags"][name]["topics"][t.name].get<std::uint64_t>()) << name << t.name;
      if (t.name == "/odom") EXPECT_EQ(t.type, "nav_msgs/msg/Odometry");
    }
    EXPECT_EQ(reader->timeRange().first, 1700000000000000000);
    EXPECT_EQ(reader->timeRange().second, 1700000000300000000);
    checkAgainstExpected(name, readAll(*reader));
    EXPECT_TRUE(reader->loss().notices.empty()) << reader->loss().notices.front();
  }
}

TEST(Mcap, PointsRawDecodesLikeTheCdrFile) {
  auto reader = openBag(fixture("ouster-lz4-chunked.mcap"));
  reader->selectTopics({"/points_raw"});
  BagMessage m;
  ASSERT_TRUE(reader->next(m));
  EXPECT_EQ(m.topic->name, "/points_raw");
  const auto direct = pointCloud2ToCloud(
      decodePointCloud2(readBytes(test::sharedData("sensors/pointcloud2-cdr/pointcloud2_64000_points.cdr")), Serialization::Cdr, "cdr"), "cdr");
  const auto via_bag = pointCloud2ToCloud(decodePointCloud2(m.data, m.topic->serialization, "bag"), "bag");
  EXPECT_EQ(via_bag.points, direct.points);
  EXPECT_EQ(via_bag.timestamps, direct.timestamps);
  EXPECT_FALSE(reader->next(m));
}

TEST(Mcap, CorruptChunkIsReportedAndSkipped) {
  for (const std::string name : {"velodyne-zstd-chunked.mcap", "ouster-lz4-chunked.mcap"}) {
    SCOPED_TRACE(name);
    auto bytes = readBytes(fixture(name));
    const auto records = topRecords(bytes);
    std::vector<TopRecord> chunks;
    for (const auto& r : records)
      if (r.opcode == 0x06) chunks.push_back(r);
    ASSERT_GE(chunks.size(), 3u);
    // Break the stored CRC of the second chunk: its data decompresses fine, so only the CRC
    // check can catch it.
    const std::uint64_t crc_at = chunks[1].offset + 9 + 24;
    bytes[crc_at] ^= 0x5A;
    const auto path = test::scratchDir() / name;
    writeBytes(path, bytes);
    auto reader = openBag(path);
    const ReadAll r = readAll(*reader);
    const BagLoss& loss = reader->loss();
    EXPECT_EQ(loss.chunks_skipped, 1u);
    ASSERT_EQ(loss.notices.size(), 1u);
    EXPECT_NE(loss.notices[0].find("offset " + std::to_string(chunks[1].offset)), std::string::npos) << loss.notices[0];
    EXPECT_NE(loss.notices[0].find("CRC mismatch"), std::string::npos) << loss.notices[0];
    int total = 0;
    for (const auto& [t, n] : r.counts) total += n;
    EXPECT_GT(total, 0);
    EXPECT_LT(total, 10);
    EXPECT_TRUE(std::is_sorted(r.times.begin(), r.times.end()));
    // The same file without its summary (scan path) reports the same chunk.
    const auto data_end = std::find_if(records.begin(), records.end(), [](const TopRecord& t) { return t.opcode == 0x0F; });
    ASSERT_NE(data_end, records.end());
    bytes.resize(data_end->offset);
    writeBytes(path, bytes);
    auto scanned = openBag(path);
    const ReadAll s = readAll(*scanned);
    EXPECT_EQ(scanned->loss().chunks_skipped, 1u);
    ASSERT_FALSE(scanned->loss().notices.empty());
    EXPECT_NE(scanned->loss().notices[0].find("offset " + std::to_string(chunks[1].offset)), std::string::npos);
    // That chunk was the first to use /odom and /thermal/image_raw, so without a summary their
    // Channel records are lost with it: the later messages are skipped, and said to be.
    EXPECT_EQ(s.counts.count("/odom"), 0u);
    EXPECT_EQ(s.counts.at("/velodyne_points"), r.counts.at("/velodyne_points"));
    ASSERT_EQ(scanned->loss().notices.size(), 3u);
    EXPECT_NE(scanned->loss().notices[1].find("channel"), std::string::npos) << scanned->loss().notices[1];
  }
}

TEST(Mcap, CorruptCompressedDataIsSkipped) {
  auto bytes = readBytes(fixture("velodyne-zstd-chunked.mcap"));
  const auto records = topRecords(bytes);
  const auto first_chunk = std::find_if(records.begin(), records.end(), [](const TopRecord& t) { return t.opcode == 0x06; });
  ASSERT_NE(first_chunk, records.end()) << "no chunk in velodyne-zstd-chunked.mcap";
  const TopRecord chunk = *first_chunk;
  // Scribble over the middle of the first chunk's compressed records.
  for (std::uint64_t i = 0; i < 64; ++i) bytes[chunk.offset + chunk.length / 2 + i] ^= 0xFF;
  const auto path = test::scratchDir() / "scribbled.mcap";
  writeBytes(path, bytes);
  auto reader = openBag(path);
  const ReadAll r = readAll(*reader);
  EXPECT_EQ(reader->loss().chunks_skipped, 1u);
  ASSERT_FALSE(reader->loss().notices.empty());
  EXPECT_NE(reader->loss().notices[0].find("offset " + std::to_string(chunk.offset)), std::string::npos);
  for (const auto& [t, cloud] : r.clouds) EXPECT_EQ(cloud.size(), 14831u);  // nothing half-decoded
}

TEST(Mcap, TruncatedFileReadsUpToTheLastCompleteMessage) {
  const auto full = readBytes(fixture("velodyne-unchunked-no-index.mcap"));
  const auto records = topRecords(full);
  std::vector<TopRecord> messages;
  for (const auto& r : records)
    if (r.opcode == 0x05) messages.push_back(r);
  ASSERT_EQ(messages.size(), 10u);
  const auto dir = test::scratchDir();
  for (const std::size_t complete : {0u, 4u, 9u}) {
    SCOPED_TRACE(complete);
    // The recorder died halfway through writing message `complete`.
    const std::uint64_t cut = messages[complete].offset + messages[complete].length / 2;
    std::vector<std::uint8_t> bytes(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut));
    writeBytes(dir / "cut.mcap", bytes);
    auto reader = openBag(dir / "cut.mcap");
    const ReadAll r = readAll(*reader);
    EXPECT_EQ(r.times.size(), complete);
    EXPECT_EQ(reader->loss().bytes_unread, cut - messages[complete].offset);
    ASSERT_EQ(reader->loss().notices.size(), 1u);
    EXPECT_NE(reader->loss().notices[0].find("truncated at offset " + std::to_string(messages[complete].offset)), std::string::npos)
        << reader->loss().notices[0];
  }
  // A chunked file cut inside its third chunk: the first two chunks' messages survive.
  const auto zstd = readBytes(fixture("velodyne-zstd-chunked.mcap"));
  const auto zrecords = topRecords(zstd);
  std::vector<TopRecord> chunks;
  for (const auto& r : zrecords)
    if (r.opcode == 0x06) chunks.push_back(r);
  ASSERT_GE(chunks.size(), 3u);
  const std::uint64_t cut = chunks[2].offset + 100;
  writeBytes(dir / "cut-chunked.mcap", std::span(zstd).first(cut));
  auto reader = openBag(dir / "cut-chunked.mcap");
  const ReadAll r = readAll(*reader);
  EXPECT_GT(r.times.size(), 0u);
  EXPECT_LT(r.times.size(), 10u);
  EXPECT_EQ(reader->loss().bytes_unread, 100u);
}

TEST(Mcap, BrokenSummaryFallsBackToScan) {
  auto bytes = readBytes(fixture("velodyne-zstd-chunked.mcap"));
  const auto records = topRecords(bytes);
  const auto data_end = std::find_if(records.begin(), records.end(), [](const TopRecord& t) { return t.opcode == 0x0F; });
  ASSERT_NE(data_end, records.end()) << "no DataEnd record";
  bytes[data_end->offset + 9 + 4 + 20] ^= 0x01;  // inside the summary's first record
  const auto path = test::scratchDir() / "summary.mcap";
  writeBytes(path, bytes);
  auto reader = openBag(path);
  ASSERT_FALSE(reader->loss().notices.empty());
  EXPECT_NE(reader->loss().notices[0].find("summary"), std::string::npos) << reader->loss().notices[0];
  checkAgainstExpected("velodyne-zstd-chunked.mcap", readAll(*reader));
}

TEST(Mcap, Rosbag2FolderWithMcapStorage) {
  const auto dir = test::scratchDir();
  fs::copy_file(fixture("velodyne-zstd-chunked.mcap"), dir / "run_0.mcap");
  std::ofstream(dir / "metadata.yaml") << "rosbag2_bagfile_information:\n  version: 8\n  storage_identifier: mcap\n"
                                          "  relative_file_paths:\n    - run_0.mcap\n  compression_format: \"\"\n";
  ASSERT_TRUE(isBag(dir));
  auto reader = openBag(dir);
  checkAgainstExpected("velodyne-zstd-chunked.mcap", readAll(*reader));
}

TEST(Mcap, NotAnMcapFailsWithOneLine) {
  const auto dir = test::scratchDir();
  std::vector<std::uint8_t> bytes = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n', 0x01, 0xFF, 0xFF};
  writeBytes(dir / "tiny.mcap", bytes);
  auto reader = openBag(dir / "tiny.mcap");  // a header cut short: nothing to read, loss said
  BagMessage m;
  EXPECT_FALSE(reader->next(m));
  EXPECT_EQ(reader->loss().bytes_unread, 3u);
  writeBytes(dir / "text.mcap", std::vector<std::uint8_t>{'h', 'e', 'l', 'l', 'o'});
  EXPECT_FALSE(isBag(dir / "text.mcap"));
  try {
    openBag(dir / "text.mcap");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("text.mcap"), std::string::npos);
  }
}

TEST(Mcap, ChunkStartingAfterItsMessagesIsSkipped) {
  // A chunk header claiming a later start than its messages would break the log-time merge:
  // the chunk is reported and skipped (scan path, where the chunk header is the only source).
  auto bytes = readBytes(fixture("velodyne-zstd-chunked.mcap"));
  const auto records = topRecords(bytes);
  std::vector<TopRecord> chunks;
  for (const auto& r : records)
    if (r.opcode == 0x06) chunks.push_back(r);
  ASSERT_GE(chunks.size(), 2u);
  const std::uint64_t late = 1700000000150000000;  // after chunk 1's messages (…001 to …100)
  std::memcpy(bytes.data() + chunks[1].offset + 9, &late, 8);
  const auto data_end = std::find_if(records.begin(), records.end(), [](const TopRecord& t) { return t.opcode == 0x0F; });
  ASSERT_NE(data_end, records.end()) << "no DataEnd record";
  bytes.resize(data_end->offset);
  const auto path = test::scratchDir() / "late.mcap";
  writeBytes(path, bytes);
  auto reader = openBag(path);
  const ReadAll r = readAll(*reader);
  EXPECT_TRUE(std::is_sorted(r.times.begin(), r.times.end()));
  EXPECT_EQ(reader->loss().chunks_skipped, 1u);
  ASSERT_FALSE(reader->loss().notices.empty());
  EXPECT_NE(reader->loss().notices[0].find("precedes the chunk's declared start"), std::string::npos) << reader->loss().notices[0];
  EXPECT_EQ(r.counts.at("/velodyne_points"), 2);
}

TEST(Mcap, SummaryWithoutChannelsIsScanned) {
  // A summary that does not repeat the Channel records (allowed by the spec; unknown opcodes
  // are skipped): the reader scans the data section for them instead of losing every message.
  auto bytes = readBytes(fixture("velodyne-zstd-chunked.mcap"));
  for (const auto& r : topRecords(bytes))
    if (r.opcode == 0x04) bytes[r.offset] = 0x80;  // only the summary has top-level channels
  std::memset(bytes.data() + bytes.size() - 8 - 4, 0, 4);  // footer summary CRC: none
  const auto path = test::scratchDir() / "no-channels.mcap";
  writeBytes(path, bytes);
  auto reader = openBag(path);
  checkAgainstExpected("velodyne-zstd-chunked.mcap", readAll(*reader));
  EXPECT_TRUE(reader->loss().notices.empty());
}
