// Tolerant decoding: real packets edited the way real firmware and networks spoil them (azimuth
// 36000, a block out of order, a truncated datagram, a packet of another model) cost only what
// is odd, are counted per kind, and a recording is refused only when nothing of it decodes.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "hazmap/sources/velodyne.hpp"
#include "pcap_builder.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using Bytes = std::vector<std::uint8_t>;
struct Packet {
  double stamp = 0;
  Bytes data;
};

std::vector<Packet> velodynePackets(const std::string& name) {
  const auto dir = test::sharedData("sensors/velodyne-" + name);
  auto bag = openBag(dir);
  std::vector<Packet> out;
  BagMessage m;
  while (bag->next(m))
    for (const LidarPacket& p : decodeVelodyneScan(m.data, m.topic->serialization, dir.string()).packets)
      out.push_back({p.stamp, p.data});
  return out;
}

std::vector<Packet> capturePackets(const std::filesystem::path& pcap) {
  PcapReader reader(pcap);
  std::vector<Packet> out;
  for (UdpPacket p; reader.next(p);) out.push_back({p.time, Bytes(p.payload.begin(), p.payload.end())});
  return out;
}

struct Decoded {
  std::vector<DecodedScan> scans;
  DecoderQuirks quirks;
};

Decoded decodeAll(PacketDecoder& decoder, const std::vector<Packet>& packets) {
  Decoded d;
  for (const Packet& p : packets) {
    decoder.addPacket(p.data, p.stamp, "test");
    while (auto s = decoder.takeScan()) d.scans.push_back(std::move(*s));
  }
  if (auto s = decoder.flush()) d.scans.push_back(std::move(*s));
  d.quirks = decoder.quirks();
  return d;
}

Decoded decodeVelodyne(const std::vector<Packet>& packets) {
  return decodeAll(*makeVelodyneDecoder({}), packets);
}

void expectSameScans(const Decoded& a, const Decoded& b) {
  ASSERT_EQ(a.scans.size(), b.scans.size());
  for (std::size_t i = 0; i < a.scans.size(); ++i) EXPECT_EQ(a.scans[i].cloud.points, b.scans[i].cloud.points) << i;
}

std::uint16_t azimuthOf(const Bytes& p, int block) { return static_cast<std::uint16_t>(p[block * 100 + 2] | (p[block * 100 + 3] << 8)); }
void setAzimuth(Bytes& p, int block, std::uint16_t az) {
  p[block * 100 + 2] = static_cast<std::uint8_t>(az & 0xff);
  p[block * 100 + 3] = static_cast<std::uint8_t>(az >> 8);
}

TEST(TolerantVelodyne, Azimuth36000IsWrappedToZero) {
  auto packets = velodynePackets("vlp16");
  const Decoded clean = decodeVelodyne(packets);
  // The VLP-16 here is in dual return: blocks (2k, 2k+1) share an azimuth. Find the pair just
  // past the wrap and say 36000 instead, as real firmware does.
  int edited = 0;
  for (std::size_t k = 1; k < packets.size() && !edited; ++k)
    for (int b = 0; b < 12; b += 2)
      if (azimuthOf(packets[k].data, b) < 40 && azimuthOf(packets[k].data, b) > 0) {
        setAzimuth(packets[k].data, b, 36000);
        setAzimuth(packets[k].data, b + 1, 36000);
        edited = 2;
        break;
      }
  ASSERT_EQ(edited, 2);
  const Decoded wrapped = decodeVelodyne(packets);
  EXPECT_EQ(wrapped.quirks.count("Velodyne block azimuths of 36000 wrapped to 0"), 2u);
  ASSERT_EQ(wrapped.scans.size(), clean.scans.size());
  // Every point is kept; the pair's points move by under 0.4° (their azimuth was below 0.4°), a
  // few of them across the cut into the neighbouring scan.
  std::size_t moved = 0, total_clean = 0, total_wrapped = 0;
  for (std::size_t i = 0; i < clean.scans.size(); ++i) {
    total_clean += clean.scans[i].cloud.size(), total_wrapped += wrapped.scans[i].cloud.size();
    moved += static_cast<std::size_t>(std::abs(static_cast<long>(clean.scans[i].cloud.size()) -
                                               static_cast<long>(wrapped.scans[i].cloud.size())));
  }
  EXPECT_EQ(total_wrapped, total_clean);
  EXPECT_LE(moved, 2u * 64u);  // at most the pair's 64 returns, counted in both scans
}

TEST(TolerantVelodyne, ABlockOutOfOrderIsSkippedAlone) {
  auto packets = velodynePackets("vlp16");
  const Decoded clean = decodeVelodyne(packets);
  const std::size_t k = packets.size() / 2;
  setAzimuth(packets[k].data, 6, azimuthOf(packets[k].data, 2));  // block 6 says block 2's azimuth
  const Decoded odd = decodeVelodyne(packets);
  EXPECT_EQ(odd.quirks.count("Velodyne blocks out of azimuth order skipped"), 1u);
  ASSERT_EQ(odd.scans.size(), clean.scans.size());  // no extra cut where the azimuth went back
  std::size_t lost = 0;
  for (std::size_t i = 0; i < clean.scans.size(); ++i) lost += clean.scans[i].cloud.size() - odd.scans[i].cloud.size();
  EXPECT_GT(lost, 0u);
  EXPECT_LE(lost, 32u);  // one block: 2 firings of 16 lasers
}

TEST(TolerantVelodyne, TruncatedDatagramAndAnotherModelAreCountedAndSkipped) {
  auto packets = velodynePackets("vlp16");
  const Decoded clean = decodeVelodyne(packets);
  const auto vlp32 = velodynePackets("vlp32");
  Packet truncated = packets[10];
  truncated.data.resize(700);
  packets.insert(packets.begin() + 20, vlp32[5]);
  packets.insert(packets.begin() + 10, truncated);
  const Decoded odd = decodeVelodyne(packets);
  expectSameScans(odd, clean);
  EXPECT_EQ(odd.quirks.count("Velodyne packets of another model (VLP-32C, expected VLP-16) skipped"), 1u);
  EXPECT_EQ(odd.quirks.count("Velodyne datagrams neither a data (1206 bytes) nor a position packet (truncated?) skipped"), 1u);
  EXPECT_EQ(odd.quirks.decoded_packets, clean.quirks.decoded_packets);
}

/// The capture with its payloads passed through `edit`, written as a new pcap.
std::filesystem::path editedCapture(const std::filesystem::path& in, const std::filesystem::path& out,
                                    const std::function<void(std::size_t, Bytes&)>& edit) {
  std::vector<test::pcap::Record> records;
  PcapReader reader(in);
  std::size_t i = 0;
  for (UdpPacket p; reader.next(p); ++i) {
    Bytes payload(p.payload.begin(), p.payload.end());
    edit(i, payload);
    const auto ip = test::pcap::ipv4Packets(test::pcap::udpSegment(payload, p.source_port, p.destination_port),
                                            static_cast<std::uint16_t>(i), 1500);
    for (const auto& frag : ip)
      records.push_back({static_cast<std::uint32_t>(p.time_ns / 1000000000),
                         static_cast<std::uint32_t>(p.time_ns % 1000000000 / 1000), test::pcap::ethernet(frag, false, false)});
  }
  return test::pcap::writeFile(out, test::pcap::pcapFile(1, false, records));
}

TEST(TolerantVelodyne, TheCountsReachInfoAndAFileOfNothingDecodableIsRefused) {
  const auto dir = test::scratchDir();
  const auto source = test::sharedData("sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap");
  const auto odd = editedCapture(source, dir / "odd.pcap", [](std::size_t i, Bytes& p) {
    if (i == 30 && p.size() == 1206) setAzimuth(p, 3, 36000);
  });
  const auto info = test::runCli("info " + odd.string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("tolerated 1 × Velodyne block azimuths of 36000 wrapped to 0"), std::string::npos)
      << info.output;
  const auto junk = editedCapture(source, dir / "junk.pcap", [](std::size_t, Bytes& p) {
    if (p.size() == 1206) p[1205] = 0x99;
  });
  const std::string e = test::errorOf([&] {
    const auto scans = openScanSource(junk);
    while (scans->next()) {
    }
  });
  EXPECT_NE(e.find(junk.string() + ": no decodable LiDAR packet"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
}

// --- Ouster: the OS-1-128 capture (RNG15_RFL8_NIR8, 1024 × 10) ------------------------------
// A packet: 32-byte header, 16 columns of a 12-byte header (timestamp u64, measurement id u16,
// status u16) and 128 pixels of 4 bytes, a 32-byte footer.
constexpr std::size_t kColumnBytes = 12 + 128 * 4;
std::size_t columnAt(std::size_t c) { return 32 + c * kColumnBytes; }

std::uint64_t countContaining(const DecoderQuirks& q, const std::string& part) {
  std::uint64_t n = 0;
  for (const auto& [kind, count] : q.counts)
    if (kind.find(part) != std::string::npos) n += count;
  return n;
}

const std::filesystem::path kOs128 = "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3";

Decoded decodeOuster(const std::vector<Packet>& packets) {
  OusterDecoder decoder(readOusterMetadata(test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10.json")));
  return decodeAll(decoder, packets);
}

std::vector<Packet> os128Packets() {
  return capturePackets(test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"));
}

/// Index of the first lidar packet (the capture interleaves IMU packets).
std::size_t firstLidar(const std::vector<Packet>& p, std::size_t from) {
  while (p[from].data.size() < 1000) ++from;
  return from;
}

TEST(TolerantOuster, AMeasurementIdBeyondTheFrameIsSkippedNotTheScan) {
  auto packets = os128Packets();
  const Decoded clean = decodeOuster(packets);
  ASSERT_EQ(clean.scans.size(), 3u);
  Bytes& p = packets[firstLidar(packets, packets.size() / 2)].data;
  p[columnAt(5) + 8] = 1024 & 0xff, p[columnAt(5) + 9] = 1024 >> 8;  // column 5 says 1024
  const Decoded odd = decodeOuster(packets);
  EXPECT_EQ(odd.quirks.count("Ouster columns with a measurement id beyond the 1024-column frame (lidar_mode "
                             "1024x10) skipped"), 1u);
  ASSERT_EQ(odd.scans.size(), clean.scans.size());  // the scan is kept, less one column
  std::size_t lost = 0;
  for (std::size_t i = 0; i < clean.scans.size(); ++i) lost += clean.scans[i].cloud.size() - odd.scans[i].cloud.size();
  EXPECT_GT(lost, 0u);
  EXPECT_LE(lost, 128u);
}

TEST(TolerantOuster, ColumnsOutOfOrderDecodeTheSame) {
  auto packets = os128Packets();
  const Decoded clean = decodeOuster(packets);
  Bytes& p = packets[firstLidar(packets, 40)].data;
  std::swap_ranges(p.begin() + static_cast<long>(columnAt(2)), p.begin() + static_cast<long>(columnAt(3)),
                   p.begin() + static_cast<long>(columnAt(9)));
  const Decoded swapped = decodeOuster(packets);
  EXPECT_EQ(swapped.quirks.total(), 0u);  // columns are placed by measurement id, as ouster-sdk does
  ASSERT_EQ(swapped.scans.size(), clean.scans.size());
  for (std::size_t i = 0; i < clean.scans.size(); ++i)
    EXPECT_EQ(swapped.scans[i].cloud.size(), clean.scans[i].cloud.size());
}

TEST(TolerantOuster, TruncatedDatagramAndAnotherModelAreCountedAndSkipped) {
  auto packets = os128Packets();
  const Decoded clean = decodeOuster(packets);
  const auto os64 = capturePackets(test::sharedData("sensors/ouster-os1-64/ouster_example.pcap"));
  Packet truncated = packets[firstLidar(packets, 100)];
  truncated.data.resize(5000);
  packets.insert(packets.begin() + static_cast<long>(firstLidar(packets, 200)), os64[firstLidar(os64, 0)]);
  packets.insert(packets.begin() + 100, truncated);
  const Decoded odd = decodeOuster(packets);
  expectSameScans(odd, clean);
  EXPECT_EQ(countContaining(odd.quirks, "lidar packets (8448 bytes; truncated, or another sensor or mode) skipped"), 2u)
      << odd.quirks.summary();
}

TEST(TolerantOuster, MetadataOfAnotherSensorRefusesTheCapture) {
  ScanSourceOptions o;
  o.sensor_metadata = test::sharedData("sensors/ouster-os1-64/ouster_example.json");
  const auto pcap = test::sharedData(kOs128.string() + ".pcap");
  const std::string e = test::errorOf([&] {
    const auto scans = openScanSource(pcap, o);
    while (scans->next()) {
    }
  });
  EXPECT_NE(e.find(pcap.string() + ": no decodable LiDAR packet"), std::string::npos) << e;
}

}  // namespace
}  // namespace hazmap
