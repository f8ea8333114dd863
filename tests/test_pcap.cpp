// Packet-capture reader: the real VLP-16 and Ouster captures (payload sizes and counts per
// port), and captures written here to cover what they lack: fragmented IPv4 and IPv6
// datagrams, Linux cooked frames, nanosecond timestamps, VLAN tags, truncated files.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "pcap_builder.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using namespace test::pcap;

struct Collected {
  std::map<std::uint16_t, std::map<std::size_t, int>> sizes_by_port;  // port → size → count
  std::vector<UdpPacket> packets;
  std::vector<Bytes> payloads;
};

Collected readAll(PcapReader& reader) {
  Collected c;
  UdpPacket p;
  while (reader.next(p)) {
    ++c.sizes_by_port[p.destination_port][p.payload.size()];
    c.packets.push_back(p);
    c.payloads.emplace_back(p.payload.begin(), p.payload.end());
  }
  return c;
}

TEST(Pcap, Vlp16CaptureHoldsDataAndPositionPackets) {
  const auto path = test::sharedData("sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap");
  ASSERT_TRUE(isPcap(path));
  PcapReader reader(path);
  const Collected c = readAll(reader);
  ASSERT_EQ(c.packets.size(), 100u);
  EXPECT_EQ(c.sizes_by_port.size(), 2u);
  EXPECT_EQ(c.sizes_by_port.at(2368).at(1206), 84);  // data packets
  EXPECT_EQ(c.sizes_by_port.at(8308).at(512), 16);   // position (GPS) packets
  EXPECT_EQ(c.packets[0].source_port, 2368);
  EXPECT_FALSE(c.packets[0].ipv6);
  EXPECT_EQ(c.packets[0].time_ns, 1415644617383637000LL);  // microsecond file, read as ns
  EXPECT_NEAR(c.packets[0].time, 1415644617.383637, 1e-6);
  // A data packet starts with a block flag and ends with the factory bytes: return mode 0x37
  // (strongest) and product id 0x21 (this 2014 firmware's; later VLP-16s say 0x22).
  EXPECT_EQ(c.payloads[0][1204], 0x37);
  EXPECT_EQ(c.payloads[0][1205], 0x21);
  EXPECT_EQ(c.payloads[0][0], 0xff);
  EXPECT_EQ(c.payloads[0][1], 0xee);
  for (std::size_t i = 1; i < c.packets.size(); ++i)
    EXPECT_GE(c.packets[i].time_ns, c.packets[i - 1].time_ns);
  EXPECT_FALSE(reader.loss().anyLost());
  EXPECT_EQ(reader.loss().other_frames, 0u);
  EXPECT_EQ(reader.framesRead(), 100u);
}

TEST(Pcap, Os1_128CaptureLidarAndImuPorts) {
  const auto path = test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  PcapReader all(path);
  const Collected c = readAll(all);
  EXPECT_EQ(c.packets.size(), 222u);
  EXPECT_EQ(c.sizes_by_port.at(7502).at(8448), 192);  // RNG15_RFL8_NIR8: 32 + 16 × 524 + 32
  EXPECT_EQ(c.sizes_by_port.at(7503).at(48), 30);     // IMU
  PcapReader lidar_only(path, PcapOptions{{7502}});
  const Collected l = readAll(lidar_only);
  EXPECT_EQ(l.packets.size(), 192u);
  EXPECT_EQ(l.sizes_by_port.size(), 1u);
  EXPECT_FALSE(lidar_only.loss().anyLost());
}

TEST(Pcap, Os1_64LegacyPackets) {
  PcapReader reader(test::sharedData("sensors/ouster-os1-64/ouster_example.pcap"), PcapOptions{{7502, 7503}});
  const Collected c = readAll(reader);
  ASSERT_EQ(c.packets.size(), 100u);
  EXPECT_EQ(c.sizes_by_port.at(7502).at(12608), 100);  // 16 columns × (16 + 64 × 12 + 4)
  EXPECT_EQ(c.packets[0].source_port, 35117);
}

// ---- captures written here --------------------------------------------------------------

/// The OS-1-64 capture's 12,608-byte payloads (legacy Ouster packets, bigger than the MTU).
std::vector<Bytes> ousterLegacyPayloads(std::size_t n) {
  PcapReader reader(test::sharedData("sensors/ouster-os1-64/ouster_example.pcap"));
  std::vector<Bytes> out;
  UdpPacket p;
  while (out.size() < n && reader.next(p)) out.emplace_back(p.payload.begin(), p.payload.end());
  return out;
}

TEST(Pcap, ReassemblesFragmentedIpv4OutOfOrderAndInterleaved) {
  const auto payloads = ousterLegacyPayloads(6);
  // Fragments of consecutive datagrams interleaved, each datagram's fragments shuffled.
  std::vector<Record> records;
  std::mt19937 rng(7);
  std::vector<std::vector<Bytes>> frags;
  for (std::size_t i = 0; i < payloads.size(); ++i) {
    frags.push_back(ipv4Packets(udpSegment(payloads[i], 7502, 7502), static_cast<std::uint16_t>(100 + i), 1500));
    ASSERT_EQ(frags.back().size(), 9u);  // 12,616 bytes of UDP in 1,480-byte fragments
    std::shuffle(frags.back().begin(), frags.back().end(), rng);
  }
  for (std::size_t i = 0; i < payloads.size(); i += 2)
    for (std::size_t k = 0; k < 9; ++k)
      for (std::size_t j = i; j < i + 2; ++j)
        records.push_back({1000, static_cast<std::uint32_t>(j * 100 + k), ethernet(frags[j][k], false, j == 3)});
  // One ARP frame, not UDP.
  records.push_back({1001, 0, Bytes{0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0, 0, 0, 0, 0, 0, 0x08, 0x06, 0, 1}});
  const auto path = writeFile(test::scratchDir() / "frag.pcap", pcapFile(1, false, records));
  PcapReader reader(path);
  const Collected c = readAll(reader);
  ASSERT_EQ(c.payloads.size(), payloads.size());
  std::vector<Bytes> sorted = c.payloads;
  for (const auto& p : payloads) EXPECT_NE(std::find(sorted.begin(), sorted.end(), p), sorted.end());
  // A datagram is stamped with the frame that completed it.
  EXPECT_EQ(c.packets[0].time_ns, 1000LL * 1'000'000'000 + 8 * 1000);
  EXPECT_FALSE(reader.loss().anyLost());
  EXPECT_EQ(reader.loss().other_frames, 1u);
}

TEST(Pcap, ReassemblesIpv6FragmentsInLinuxCookedFramesWithNanoseconds) {
  const auto payloads = ousterLegacyPayloads(2);
  std::vector<Record> records;
  for (std::size_t i = 0; i < payloads.size(); ++i)
    for (const Bytes& ip : ipv6Packets(udpSegment(payloads[i], 40000, 7502), 77 + i, 1280))
      records.push_back({5, static_cast<std::uint32_t>(123456789 + i), linuxCooked(ip, true)});
  // An unfragmented IPv6 datagram and an IPv4 one, both to the IMU port.
  records.push_back({6, 1, linuxCooked(ipv6Packets(udpSegment(Bytes(48, 7), 40001, 7503), 0, 0)[0], true)});
  records.push_back({6, 2, linuxCooked(ipv4Packets(udpSegment(Bytes(48, 9), 40001, 7503), 1, 0)[0], false)});
  const auto path = writeFile(test::scratchDir() / "v6.pcap", pcapFile(113, true, records));
  PcapReader reader(path);
  const Collected c = readAll(reader);
  ASSERT_EQ(c.packets.size(), 4u);
  EXPECT_EQ(c.payloads[0], payloads[0]);
  EXPECT_EQ(c.payloads[1], payloads[1]);
  EXPECT_TRUE(c.packets[0].ipv6);
  EXPECT_EQ(c.packets[0].time_ns, 5'123'456'789LL);  // nanosecond file keeps its nanoseconds
  EXPECT_EQ(c.packets[0].source_port, 40000);
  EXPECT_EQ(c.payloads[2], Bytes(48, 7));
  EXPECT_TRUE(c.packets[2].ipv6);
  EXPECT_EQ(c.payloads[3], Bytes(48, 9));
  EXPECT_FALSE(c.packets[3].ipv6);
  EXPECT_FALSE(reader.loss().anyLost());
}

TEST(Pcap, MissingFragmentIsReportedNotDecoded) {
  const auto payloads = ousterLegacyPayloads(3);
  std::vector<Record> records;
  for (std::size_t i = 0; i < payloads.size(); ++i) {
    auto frags = ipv4Packets(udpSegment(payloads[i], 7502, 7502), static_cast<std::uint16_t>(i), 1500);
    if (i == 1) frags.erase(frags.begin() + 4);
    for (const Bytes& ip : frags) records.push_back({1, 0, ethernet(ip, false, false)});
  }
  PcapReader reader(writeFile(test::scratchDir() / "lost.pcap", pcapFile(1, false, records)));
  const Collected c = readAll(reader);
  ASSERT_EQ(c.payloads.size(), 2u);
  EXPECT_EQ(c.payloads[0], payloads[0]);
  EXPECT_EQ(c.payloads[1], payloads[2]);
  EXPECT_EQ(reader.loss().incomplete_datagrams, 1u);
  ASSERT_FALSE(reader.loss().notices.empty());
  EXPECT_NE(reader.loss().notices[0].find("lost.pcap"), std::string::npos);
}

TEST(Pcap, TruncatedCaptureReadsCompleteRecordsAndReportsTheRest) {
  const auto src = test::sharedData("sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap");
  Bytes bytes(std::filesystem::file_size(src));
  std::ifstream(src, std::ios::binary).read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const auto dir = test::scratchDir();
  // Cut mid-way through the last record's data (a recorder killed mid-write).
  bytes.resize(bytes.size() - 700);
  PcapReader reader(writeFile(dir / "cut.pcap", bytes));
  const Collected c = readAll(reader);
  EXPECT_EQ(c.packets.size(), 99u);
  EXPECT_EQ(reader.loss().bytes_unread, 16u + 1248u - 700u);
  ASSERT_EQ(reader.loss().notices.size(), 1u);
  EXPECT_NE(reader.loss().notices[0].find("cut.pcap"), std::string::npos);
  // Cut inside a record header.
  bytes.resize(24 + 16 + 1248 + 10);
  PcapReader header_cut(writeFile(dir / "cut2.pcap", bytes));
  EXPECT_EQ(readAll(header_cut).packets.size(), 1u);
  EXPECT_EQ(header_cut.loss().bytes_unread, 10u);
}

TEST(Pcap, SnappedRecordsAreCountedAndSkipped) {
  const Bytes payload(1206, 3);
  const Bytes frame = ethernet(ipv4Packets(udpSegment(payload, 2368, 2368), 0, 0)[0], false, false);
  const Bytes snapped(frame.begin(), frame.begin() + 200);
  const auto path = writeFile(test::scratchDir() / "snap.pcap",
                              pcapFile(1, false, {{1, 0, frame}, {1, 1, snapped, static_cast<std::uint32_t>(frame.size())}}));
  PcapReader reader(path);
  EXPECT_EQ(readAll(reader).packets.size(), 1u);
  EXPECT_EQ(reader.loss().snapped_frames, 1u);
}

TEST(Pcap, BadFilesFailNamingTheFile) {
  const auto dir = test::scratchDir();
  auto expectError = [](const std::filesystem::path& path, const std::string& what) {
    try {
      PcapReader reader(path);
      FAIL() << "no error for " << path;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path.filename().string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expectError(dir / "missing.pcap", "cannot open");
  expectError(writeFile(dir / "text.pcap", Bytes{'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r', 'l', 'd', '\n'}),
              "not a readable packet capture");
  Bytes header = pcapFile(1, false, {});
  header.resize(10);
  expectError(writeFile(dir / "short.pcap", header), "not a readable packet capture");
  expectError(writeFile(dir / "usb.pcap", pcapFile(189, false, {})), "link type 189");
  EXPECT_FALSE(isPcap(dir / "text.pcap"));
  EXPECT_FALSE(isPcap(dir / "missing.pcap"));
}

/// A pcapng file: section header, one Ethernet interface (microsecond resolution), enhanced
/// packet blocks.
Bytes pcapngFile(const std::vector<Record>& records) {
  Bytes f;
  auto u32 = [&](std::uint32_t v) { for (int i = 0; i < 4; ++i) f.push_back((v >> (8 * i)) & 0xff); };
  auto u16 = [&](std::uint16_t v) { f.push_back(v & 0xff); f.push_back(v >> 8); };
  u32(0x0a0d0d0a), u32(28), u32(0x1a2b3c4d), u16(1), u16(0), u32(0xffffffff), u32(0xffffffff), u32(28);
  u32(1), u32(20), u16(1), u16(0), u32(0), u32(20);  // interface: LINKTYPE_ETHERNET, no snap limit
  for (const Record& r : records) {
    const std::uint32_t padded = static_cast<std::uint32_t>((r.frame.size() + 3) / 4 * 4);
    const std::uint64_t ts = std::uint64_t{r.sec} * 1'000'000 + r.sub;
    u32(6), u32(32 + padded), u32(0), u32(static_cast<std::uint32_t>(ts >> 32)), u32(static_cast<std::uint32_t>(ts));
    u32(static_cast<std::uint32_t>(r.frame.size())), u32(static_cast<std::uint32_t>(r.frame.size()));
    f.insert(f.end(), r.frame.begin(), r.frame.end());
    f.resize(f.size() + (padded - r.frame.size()), 0);
    u32(32 + padded);
  }
  return f;
}

TEST(Pcap, ReadsPcapng) {
  const Bytes payload(1206, 5);
  const Bytes frame = ethernet(ipv4Packets(udpSegment(payload, 2368, 2368), 0, 0)[0], false, false);
  const auto path = writeFile(test::scratchDir() / "capture.pcapng", pcapngFile({{100, 250, frame}, {100, 1250, frame}}));
  EXPECT_TRUE(isPcap(path));
  PcapReader reader(path);
  const Collected c = readAll(reader);
  ASSERT_EQ(c.packets.size(), 2u);
  EXPECT_EQ(c.payloads[1], payload);
  EXPECT_EQ(c.packets[1].time_ns, 100'001'250'000LL);
  EXPECT_FALSE(reader.loss().anyLost());
}

TEST(Pcap, ReadsFromMemoryStream) {
  const Bytes payload(100, 42);
  Bytes file = pcapFile(101, false, {{3, 4, ipv4Packets(udpSegment(payload, 1, 2), 0, 0)[0]}});  // LINKTYPE_RAW
  PcapReader reader(fmemopen(file.data(), file.size(), "rb"), "memory");
  const Collected c = readAll(reader);
  ASSERT_EQ(c.payloads.size(), 1u);
  EXPECT_EQ(c.payloads[0], payload);
  EXPECT_EQ(c.packets[0].destination_port, 2);
}

}  // namespace
}  // namespace hazmap
