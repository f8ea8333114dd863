// Velodyne packet decoder: nebula's decoded clouds of the real VLP-16, VLP-32C and VLS-128
// recordings as the oracle, the VLP-16 capture, calibration files and bad packets.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>

#include <pcap/pcap.h>
#include <sqlite3.h>

#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/sources/velodyne.hpp"
#include "test_helpers.hpp"

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

struct Packet {
  double stamp;
  std::vector<std::uint8_t> data;
};
struct Message {
  std::int64_t log_time_ns;
  std::vector<Packet> packets;
};

// FALLBACK until the rosbag2 reader lands: the .db3's messages table, VelodyneScan CDR
// (encapsulation header, header{stamp, frame_id}, packets[]{stamp, uint8[1206]}).
std::vector<Message> loadMessages(const std::string& name) {
  const fs::path dir = test::sharedData("sensors/velodyne-" + name);
  fs::path db;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".db3") db = e.path();
  sqlite3* handle = nullptr;
  EXPECT_EQ(sqlite3_open_v2(db.c_str(), &handle, SQLITE_OPEN_READONLY, nullptr), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(handle, "SELECT timestamp, data FROM messages ORDER BY timestamp", -1, &st,
                     nullptr);
  std::vector<Message> out;
  while (sqlite3_step(st) == SQLITE_ROW) {
    const auto* d = static_cast<const std::uint8_t*>(sqlite3_column_blob(st, 1));
    const std::size_t size = static_cast<std::size_t>(sqlite3_column_bytes(st, 1));
    auto u32 = [&](std::size_t o) { std::uint32_t v; std::memcpy(&v, d + o, 4); return v; };
    std::size_t o = 4 + 8;
    o += 4 + u32(o);
    o = (o + 3) & ~std::size_t{3};
    const std::uint32_t n = u32(o);
    o += 4;
    Message m{sqlite3_column_int64(st, 0), {}};
    for (std::uint32_t i = 0; i < n && o + 8 + 1206 <= size; ++i) {
      o = (o + 3) & ~std::size_t{3};
      const double stamp = static_cast<std::int32_t>(u32(o)) + u32(o + 4) * 1e-9;
      m.packets.push_back({stamp, std::vector<std::uint8_t>(d + o + 8, d + o + 8 + 1206)});
      o += 8 + 1206;
    }
    out.push_back(std::move(m));
  }
  sqlite3_finalize(st);
  sqlite3_close(handle);
  return out;
}

/// The scan the decoder completes while it is fed the message logged at `log_time_ns`, as
/// nebula's test names its ground truth.
DecodedScan scanCompletedIn(const std::vector<Message>& messages, std::int64_t log_time_ns,
                            const VelodyneOptions& options) {
  auto decoder = makeVelodyneDecoder(options);
  std::optional<DecodedScan> found;
  for (const Message& m : messages) {
    for (const Packet& p : m.packets) {
      decoder->addPacket(p.data, p.stamp, "test");
      while (auto scan = decoder->takeScan())
        if (m.log_time_ns == log_time_ns) found = std::move(scan);
    }
  }
  EXPECT_TRUE(found.has_value());
  return found ? std::move(*found) : DecodedScan{};
}

struct Comparison {
  std::size_t ours = 0, theirs = 0;
  double max_error = 0;  ///< m, point i against point i
};

Comparison compareInOrder(const LabeledCloud& ours, const LabeledCloud& theirs) {
  Comparison c{ours.size(), theirs.size(), 0.0};
  for (std::size_t i = 0; i < std::min(ours.size(), theirs.size()); ++i)
    c.max_error = std::max(c.max_error,
                           static_cast<double>((ours.points[i] - theirs.points[i]).norm()));
  return c;
}

void expectNebulaCloud(const std::string& name, const std::string& pcd,
                       const VelodyneOptions& options) {
  const auto messages = loadMessages(name);
  const std::int64_t stamp = std::stoll(fs::path(pcd).stem().string());
  const DecodedScan scan = scanCompletedIn(messages, stamp, options);
  const LabeledCloud truth = readPcd(test::sharedData("sensors/velodyne-" + name + "/" + pcd));
  const Comparison c = compareInOrder(scan.cloud, truth);
  EXPECT_EQ(c.ours, c.theirs) << name;
  EXPECT_LE(c.max_error, 1e-3) << name;
  std::printf("%s: %zu points (nebula %zu), max error in order %.3g m\n", name.c_str(), c.ours,
              c.theirs, c.max_error);
}

}  // namespace

// Settings of nebula's decoder tests (tier4/nebula, src/nebula_velodyne/nebula_velodyne/tests/):
// VLP-16 dual, 0.3–300 m, scan phase 0, cloud angles 0–359.
TEST(VelodyneNebula, Vlp16DualReturn) {
  VelodyneOptions o;
  o.min_range = 0.3;
  o.max_range = 300;
  o.cut_angle = 0;
  o.fov_min = 0;
  o.fov_max = 359;
  expectNebulaCloud("vlp16", "1673400472138016708.pcd", o);
}

// VLP-32C single strongest, 0.4–50 m, scan phase 180, cloud angles 270–90.
TEST(VelodyneNebula, Vlp32cStrongest) {
  VelodyneOptions o;
  o.min_range = 0.4;
  o.max_range = 50;
  o.cut_angle = 180;
  o.fov_min = 270;
  o.fov_max = 90;
  expectNebulaCloud("vlp32", "1713492677464078412.pcd", o);
}

// VLS-128 (the packets say single strongest), 0.3–300 m, scan phase 0, cloud angles 0–359.
TEST(VelodyneNebula, Vls128) {
  VelodyneOptions o;
  o.min_range = 0.3;
  o.max_range = 300;
  o.cut_angle = 0;
  o.fov_min = 0;
  o.fov_max = 359;
  expectNebulaCloud("vls128", "1585897255376374245.pcd", o);
}
