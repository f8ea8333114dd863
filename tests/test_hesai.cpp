// Hesai packet decoder: nebula's decoded clouds of the real Pandar40P, Pandar64, PandarXT32 and
// PandarQT128 recordings as the oracle; for the models without a recording (QT64, XT16, XT32M)
// packets built from the manuals' layouts against hand-computed points; angle-correction files,
// tolerant decoding and the bag / capture / CLI paths.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/hesai.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "pcap_builder.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

struct Packet {
  double stamp = 0;
  Bytes data;
};
struct Message {
  std::int64_t log_time_ns = 0;
  std::vector<Packet> packets;
};

/// The PandarScan messages of a recording's rosbag2 folder.
std::vector<Message> loadMessages(const fs::path& folder) {
  fs::path bag;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_directory()) bag = e.path();
  auto reader = openBag(bag);
  std::vector<Message> out;
  BagMessage m;
  while (reader->next(m)) {
    const VelodyneScanMsg scan = decodePandarScan(m.data, m.topic->serialization, bag.string());
    Message msg{m.log_time_ns, {}};
    for (const LidarPacket& p : scan.packets) msg.packets.push_back({p.stamp, p.data});
    out.push_back(std::move(msg));
  }
  return out;
}

fs::path fileWithExtension(const fs::path& folder, const std::string& ext) {
  for (const auto& e : fs::directory_iterator(folder))
    if (e.path().extension() == ext) return e.path();
  ADD_FAILURE() << "no " << ext << " in " << folder;
  return {};
}

struct NebulaCase {
  const char* folder;
  HesaiModel model;
  double min_range, max_range;
};
void PrintTo(const NebulaCase& c, std::ostream* os) { *os << c.folder; }

class HesaiNebula : public ::testing::TestWithParam<NebulaCase> {};

/// The scan completed while the decoder is fed the message the reference cloud is named after
/// (as nebula's decoder test names it), against that cloud: same count, every point within 1 mm
/// of its counterpart in nebula's order. nebula's Hesai frame is x right, y forward; ours x
/// forward, y left.
TEST_P(HesaiNebula, SameCloudAsTheDriver) {
  const NebulaCase& c = GetParam();
  const fs::path folder = test::sharedData(std::string("sensors/") + c.folder);
  const auto messages = loadMessages(folder);
  const fs::path pcd = fileWithExtension(folder, ".pcd");
  const std::int64_t stamp = std::stoll(pcd.stem().string());
  HesaiOptions o;
  o.calibration_file = fileWithExtension(folder, ".csv");
  o.min_range = c.min_range;
  o.max_range = c.max_range;
  auto decoder = makeHesaiDecoder(o);
  std::optional<DecodedScan> found;
  for (const Message& m : messages)
    for (const Packet& p : m.packets) {
      decoder->addPacket(p.data, p.stamp, "test");
      while (auto scan = decoder->takeScan())
        if (m.log_time_ns == stamp) found = std::move(scan);
    }
  ASSERT_TRUE(found.has_value());
  EXPECT_EQ(decoder->quirks().total(), 0u) << decoder->quirks().summary();
  EXPECT_NE(decoder->describe().find(hesaiModelName(c.model)), std::string::npos) << decoder->describe();
  const LabeledCloud truth = readPcd(pcd);
  ASSERT_EQ(found->cloud.size(), truth.size());
  double worst = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const Eigen::Vector3f nebula(truth.points[i].y(), -truth.points[i].x(), truth.points[i].z());
    worst = std::max(worst, static_cast<double>((found->cloud.points[i] - nebula).norm()));
  }
  EXPECT_LE(worst, 1e-3);
  std::printf("%s: %zu points (nebula %zu), max error in order %.3g m\n", c.folder, found->cloud.size(), truth.size(),
              worst);
}

// The README's driver settings: 40P and 64 dual return 0.3–200 m, XT32 dual 0.05–120 m, QT128
// last+strongest 0.3–300 m; 0–360°, cut at 0.
INSTANTIATE_TEST_SUITE_P(HesaiRecordings, HesaiNebula,
                         ::testing::Values(NebulaCase{"hesai-pandar40p", HesaiModel::Pandar40P, 0.3, 200},
                                           NebulaCase{"hesai-pandar64", HesaiModel::Pandar64, 0.3, 200},
                                           NebulaCase{"hesai-xt32", HesaiModel::PandarXT32, 0.05, 120},
                                           NebulaCase{"hesai-qt128", HesaiModel::PandarQT128, 0.3, 300}),
                         [](const auto& info) {
                           std::string n = info.param.folder;
                           return n.substr(6);
                         });

TEST(HesaiModels, TheModelIsReadFromThePacket) {
  const std::pair<const char*, HesaiModel> cases[] = {{"hesai-pandar40p", HesaiModel::Pandar40P},
                                                      {"hesai-pandar64", HesaiModel::Pandar64},
                                                      {"hesai-xt32", HesaiModel::PandarXT32},
                                                      {"hesai-qt128", HesaiModel::PandarQT128}};
  for (const auto& [folder, model] : cases) {
    const auto messages = loadMessages(test::sharedData(std::string("sensors/") + folder));
    const auto got = hesaiModelOfPacket(messages[0].packets[0].data);
    ASSERT_TRUE(got.has_value()) << folder;
    EXPECT_EQ(*got, model) << folder;
    Bytes cut = messages[0].packets[0].data;
    cut.resize(cut.size() / 2);
    EXPECT_FALSE(hesaiModelOfPacket(cut).has_value()) << folder;
  }
  EXPECT_EQ(hesaiModelFromName("xt32m"), HesaiModel::PandarXT32M);
  EXPECT_EQ(hesaiModelFromName("PandarQT128"), HesaiModel::PandarQT128);
  EXPECT_FALSE(hesaiModelFromName("XT64").has_value());
}

// --- Models without a recording: packets laid out as their manuals say --------------------

struct Synthetic {
  HesaiModel model;
  int blocks, channels;
  std::size_t tail_mode_at;  ///< the return-mode byte's offset in the tail
  std::size_t tail_bytes;    ///< tail + UDP sequence
};

/// A 12-byte-header packet (0xEEFF, protocol 6.1, lasers, blocks, distance unit 4 mm, returns),
/// blocks of {azimuth, channels × {distance, reflectivity, 0}}, the tail with `mode`.
Bytes makePacket(const Synthetic& s, const std::vector<std::uint16_t>& azimuths, std::uint8_t mode,
                 const std::function<std::uint16_t(int block, int channel)>& distance) {
  const std::size_t block_bytes = 2 + 4 * static_cast<std::size_t>(s.channels);
  Bytes p(12 + s.blocks * block_bytes + s.tail_bytes, 0);
  p[0] = 0xee, p[1] = 0xff, p[2] = 6, p[3] = 1;
  p[6] = static_cast<std::uint8_t>(s.channels), p[7] = static_cast<std::uint8_t>(s.blocks), p[9] = 4;
  p[10] = mode >= 0x39 ? 2 : 1;
  for (int b = 0; b < s.blocks; ++b) {
    std::uint8_t* block = &p[12 + b * block_bytes];
    block[0] = azimuths[b] & 0xff, block[1] = azimuths[b] >> 8;
    for (int c = 0; c < s.channels; ++c) {
      const std::uint16_t d = distance(b, c);
      block[2 + 4 * c] = d & 0xff, block[3 + 4 * c] = d >> 8, block[4 + 4 * c] = static_cast<std::uint8_t>(10 + b);
    }
  }
  p[12 + s.blocks * block_bytes + s.tail_mode_at] = mode;
  return p;
}

/// The point a return at `distance_m` of channel c at block azimuth `azimuth_deg` must be, by hand:
/// azimuth + the channel's offset, clockwise from the front; x forward, y left.
Eigen::Vector3d expected(const HesaiCalibration& cal, int c, double azimuth_deg, double distance_m) {
  const double az = (azimuth_deg + cal.azimuth_deg[c]) * M_PI / 180, el = cal.elevation_deg[c] * M_PI / 180;
  return {distance_m * std::cos(el) * std::cos(az), -distance_m * std::cos(el) * std::sin(az),
          distance_m * std::sin(el)};
}

void expectPoints(const DecodedScan& scan, const std::vector<Eigen::Vector3d>& want) {
  ASSERT_EQ(scan.cloud.size(), want.size());
  for (std::size_t i = 0; i < want.size(); ++i)
    EXPECT_LT((scan.cloud.points[i].cast<double>() - want[i]).norm(), 2e-5 * want[i].norm() + 1e-6) << i;
}

TEST(HesaiSynthetic, Xt16SingleReturnHandComputed) {
  const Synthetic xt16{HesaiModel::PandarXT16, 8, 16, 10, 28};
  std::vector<std::uint16_t> az;
  for (int b = 0; b < 8; ++b) az.push_back(static_cast<std::uint16_t>(9000 + 18 * b));
  const auto distance = [](int b, int c) { return static_cast<std::uint16_t>(c == 3 ? 0 : 1000 + 37 * c + b); };
  const Bytes p = makePacket(xt16, az, 0x37, distance);
  ASSERT_EQ(p.size(), 568u);
  ASSERT_EQ(hesaiModelOfPacket(p), HesaiModel::PandarXT16);
  auto decoder = makeHesaiDecoder();
  decoder->addPacket(p, 100.0, "xt16");
  const auto scan = decoder->flush();
  ASSERT_TRUE(scan.has_value());
  const HesaiCalibration cal = hesaiDefaultCalibration(HesaiModel::PandarXT16);
  EXPECT_DOUBLE_EQ(cal.elevation_deg[0], 15.0);
  EXPECT_DOUBLE_EQ(cal.elevation_deg[15], -15.0);
  std::vector<Eigen::Vector3d> want;
  for (int b = 0; b < 8; ++b)
    for (int c = 0; c < 16; ++c)
      if (c != 3) want.push_back(expected(cal, c, az[b] / 100.0, 0.004 * distance(b, c)));
  expectPoints(*scan, want);
  // Ring 0 is the lowest channel (the last, −15°); times: 50 µs a firing, the packet time
  // 5.632 µs after the last one's start, channels 3.024 µs apart.
  EXPECT_EQ(scan->ring[0], 15);
  EXPECT_NEAR(scan->cloud.timestamps[0], 100.0 + (5632 - 7 * 50000 + 368) * 1e-9, 1e-9);
  EXPECT_NEAR(scan->cloud.timestamps[1] - scan->cloud.timestamps[0], 3024e-9, 1e-10);
  EXPECT_EQ(decoder->quirks().total(), 0u);
}

TEST(HesaiSynthetic, Qt64DualReturnKeepsDistinctReturnsOnly) {
  const Synthetic qt64{HesaiModel::PandarQT64, 4, 64, 16, 28};
  const std::vector<std::uint16_t> az = {9000, 9000, 9060, 9060};
  // Even blocks the last return, odd ones the strongest: channel c's pair is identical (c % 3 ==
  // 0), 8 cm apart (c % 3 == 1, closer than nebula's 0.1 m: only the last kept) or 2 m apart.
  const auto distance = [](int b, int c) {
    const int last = 2000 + 10 * c, gap = c % 3 == 0 ? 0 : c % 3 == 1 ? 20 : 500;
    return static_cast<std::uint16_t>(b % 2 == 0 ? last : last + gap);
  };
  Bytes p = makePacket(qt64, az, 0x39, [&](int b, int c) { return distance(b, c); });
  for (int b = 0; b < 4; ++b)  // identical pairs must share their reflectivity too
    for (int c = 0; c < 64; c += 3) p[12 + b * 258 + 4 + 4 * c] = 50;
  ASSERT_EQ(p.size(), 1072u);
  auto decoder = makeHesaiDecoder();
  decoder->addPacket(p, 0.0, "qt64");
  const auto scan = decoder->flush();
  ASSERT_TRUE(scan.has_value());
  const HesaiCalibration cal = hesaiDefaultCalibration(HesaiModel::PandarQT64);
  std::vector<Eigen::Vector3d> want;
  std::vector<std::uint8_t> types;
  for (int f = 0; f < 2; ++f)
    for (int c = 0; c < 64; ++c) {
      if (c % 3 == 2) want.push_back(expected(cal, c, az[2 * f] / 100.0, 0.004 * distance(2 * f, c))), types.push_back(1);
      want.push_back(expected(cal, c, az[2 * f] / 100.0, 0.004 * distance(2 * f + 1, c)));
      types.push_back(2);
    }
  expectPoints(*scan, want);
  EXPECT_EQ(scan->return_type, types);
}

TEST(HesaiSynthetic, Xt32mTripleReturnAndTheScanCut) {
  const Synthetic xt32m{HesaiModel::PandarXT32M, 6, 32, 10, 28};
  auto decoder = makeHesaiDecoder();
  std::vector<DecodedScan> scans;
  // Two firings a packet, 0.36° apart: packets from 350° through the cut at 0° to 10°.
  for (int k = 0; k < 56; ++k) {
    const auto a = static_cast<std::uint16_t>((35000 + 72 * k) % 36000), b = static_cast<std::uint16_t>((a + 36) % 36000);
    const Bytes p = makePacket(xt32m, {a, a, a, b, b, b}, 0x3d, [](int blk, int c) {
      return static_cast<std::uint16_t>(1000 + 300 * (blk % 3) + c);
    });
    ASSERT_EQ(p.size(), 820u);
    decoder->addPacket(p, k * 1e-3, "xt32m");
    while (auto s = decoder->takeScan()) scans.push_back(std::move(*s));
  }
  // The scan before the cut is complete once every channel has passed 0°; each point is in the
  // scan its own azimuth (block + offset) falls in.
  ASSERT_EQ(scans.size(), 1u);
  const HesaiCalibration cal = hesaiDefaultCalibration(HesaiModel::PandarXT32M);
  std::size_t want = 0;
  for (int k = 0; k < 56; ++k)
    for (int f = 0; f < 2; ++f) {
      const double block = 350.0 + 0.72 * k + 0.36 * f;
      for (int c = 0; c < 32; ++c)
        if (block + cal.azimuth_deg[c] < 360.0) want += 3;
    }
  EXPECT_EQ(scans[0].cloud.size(), want);
  for (std::size_t i = 0; i < scans[0].cloud.size(); ++i) {
    const Eigen::Vector3f& q = scans[0].cloud.points[i];
    EXPECT_GT(std::atan2(q.y(), q.x()), -1e-6) << i;  // azimuth (clockwise) below 360°: y ≥ 0 (left)
  }
  EXPECT_EQ(scans[0].return_type.front(), 1);
  EXPECT_EQ(scans[0].return_type[2], 3);
}

// --- Angle-correction files ---------------------------------------------------------------

TEST(HesaiCalibrationFile, TheRecordingsFilesAreTheBuiltInOnes) {
  const std::pair<const char*, HesaiModel> cases[] = {{"hesai-pandar40p", HesaiModel::Pandar40P},
                                                      {"hesai-pandar64", HesaiModel::Pandar64},
                                                      {"hesai-xt32", HesaiModel::PandarXT32},
                                                      {"hesai-qt128", HesaiModel::PandarQT128}};
  for (const auto& [folder, model] : cases) {
    const HesaiCalibration file =
        loadHesaiCalibration(fileWithExtension(test::sharedData(std::string("sensors/") + folder), ".csv"), model);
    const HesaiCalibration builtin = hesaiDefaultCalibration(model);
    EXPECT_EQ(file.elevation_deg, builtin.elevation_deg) << folder;
    EXPECT_EQ(file.azimuth_deg, builtin.azimuth_deg) << folder;
  }
  for (HesaiModel m : {HesaiModel::PandarQT64, HesaiModel::PandarXT16, HesaiModel::PandarXT32M})
    EXPECT_EQ(hesaiDefaultCalibration(m).elevation_deg.size(), static_cast<std::size_t>(hesaiChannelCount(m)));
}

TEST(HesaiCalibrationFile, MalformedFilesNameTheFileAndLine) {
  std::string good = "Channel,Elevation,Azimuth\n";
  for (int c = 1; c <= 16; ++c) good += std::to_string(c) + "," + std::to_string(15 - 2 * c) + ",0.5\r\n";
  EXPECT_EQ(parseHesaiCalibration(good, HesaiModel::PandarXT16, "x.csv").azimuth_deg[15], 0.5);
  const auto error = [&](std::string text, HesaiModel m = HesaiModel::PandarXT16) {
    return test::errorOf([&] { parseHesaiCalibration(text, m, "cal.csv"); });
  };
  std::string bad = good;
  bad.replace(bad.find("3,9,0.5"), 7, "3,nine,0.5");
  EXPECT_NE(error(bad).find("cal.csv:4: expected 'id,elevation,azimuth'"), std::string::npos) << error(bad);
  bad = good;
  bad.replace(bad.find("3,9,0.5"), 7, "2,9,0.5");
  EXPECT_NE(error(bad).find("cal.csv:4: channel 2 given twice"), std::string::npos) << error(bad);
  EXPECT_NE(error(good + "17,0,0\n").find("cal.csv:18: channel id 17 is not 1…16"), std::string::npos);
  EXPECT_NE(error(good, HesaiModel::PandarXT32).find("cal.csv: 16 channels, PandarXT32 has 32"), std::string::npos);
  EXPECT_NE(error("1,2,3\n").find("cal.csv:1: not a Hesai angle-correction file"), std::string::npos);
  EXPECT_NE(error(good.substr(0, good.size() - 2) + ",7\n").find("cal.csv:17:"), std::string::npos);
  bad = good;
  bad.replace(bad.find("3,9,0.5"), 7, "3,95,0.5");
  EXPECT_NE(error(bad).find("cal.csv:4: angles out of range"), std::string::npos) << error(bad);
  EXPECT_NE(test::errorOf([] { loadHesaiCalibration("/nonexistent/x.csv", HesaiModel::PandarXT16); })
                .find("/nonexistent/x.csv: cannot open"),
            std::string::npos);
}

// --- Tolerant decoding, on the real XT32 packets (dual return: a firing is two blocks) -------

std::vector<Packet> xt32Packets() {
  std::vector<Packet> out;
  for (const auto& m : loadMessages(test::sharedData("sensors/hesai-xt32")))
    out.insert(out.end(), m.packets.begin(), m.packets.end());
  return out;
}

struct Decoded {
  std::vector<DecodedScan> scans;
  DecoderQuirks quirks;
  std::size_t points() const {
    std::size_t n = 0;
    for (const auto& s : scans) n += s.cloud.size();
    return n;
  }
};

Decoded decodeAll(const std::vector<Packet>& packets, const HesaiOptions& o = {}) {
  auto decoder = makeHesaiDecoder(o);
  Decoded d;
  for (const Packet& p : packets) {
    decoder->addPacket(p.data, p.stamp, "test");
    while (auto s = decoder->takeScan()) d.scans.push_back(std::move(*s));
  }
  while (auto s = decoder->flush()) d.scans.push_back(std::move(*s));
  d.quirks = decoder->quirks();
  return d;
}

constexpr std::size_t kXt32Block = 2 + 32 * 4;
void setXt32Azimuth(Bytes& p, int block, std::uint16_t az) {
  p[12 + block * kXt32Block] = az & 0xff;
  p[13 + block * kXt32Block] = az >> 8;
}
std::uint16_t xt32Azimuth(const Bytes& p, int block) {
  return static_cast<std::uint16_t>(p[12 + block * kXt32Block] | (p[13 + block * kXt32Block] << 8));
}

TEST(HesaiTolerant, Azimuth36000IsWrappedToZero) {
  auto packets = xt32Packets();
  const Decoded clean = decodeAll(packets);
  bool edited = false;
  for (std::size_t k = 1; k < packets.size() && !edited; ++k)
    for (int b = 0; b < 8 && !edited; b += 2)
      if (xt32Azimuth(packets[k].data, b) == 0) {  // this sensor's firings land on 0 exactly
        setXt32Azimuth(packets[k].data, b, 36000);
        setXt32Azimuth(packets[k].data, b + 1, 36000);
        edited = true;
      }
  ASSERT_TRUE(edited);
  const Decoded wrapped = decodeAll(packets);
  EXPECT_EQ(wrapped.quirks.count("Hesai block azimuths of 36000 wrapped to 0"), 1u);
  ASSERT_EQ(wrapped.scans.size(), clean.scans.size());
  for (std::size_t i = 0; i < clean.scans.size(); ++i)
    EXPECT_EQ(wrapped.scans[i].cloud.points, clean.scans[i].cloud.points) << i;
}

TEST(HesaiTolerant, AFiringOutOfOrderIsSkippedAlone) {
  auto packets = xt32Packets();
  const Decoded clean = decodeAll(packets);
  Bytes& p = packets[packets.size() / 2].data;
  setXt32Azimuth(p, 4, static_cast<std::uint16_t>(xt32Azimuth(p, 0) - 100));  // firing 2 a degree back
  setXt32Azimuth(p, 5, static_cast<std::uint16_t>(xt32Azimuth(p, 0) - 100));
  const Decoded odd = decodeAll(packets);
  EXPECT_EQ(odd.quirks.count("Hesai firings out of azimuth order skipped"), 1u);
  ASSERT_EQ(odd.scans.size(), clean.scans.size());  // no extra cut where it went back
  EXPECT_LT(odd.points(), clean.points());
  EXPECT_GE(odd.points() + 64, clean.points());
}

TEST(HesaiTolerant, TruncatedDatagramAndAnotherModelAreCountedAndSkipped) {
  auto packets = xt32Packets();
  const Decoded clean = decodeAll(packets);
  Packet truncated = packets[30];
  truncated.data.resize(700);
  const auto qt128 = loadMessages(test::sharedData("sensors/hesai-qt128"));
  packets.insert(packets.begin() + 200, qt128[0].packets[7]);
  packets.insert(packets.begin() + 30, truncated);
  const Decoded odd = decodeAll(packets);
  ASSERT_EQ(odd.scans.size(), clean.scans.size());
  for (std::size_t i = 0; i < clean.scans.size(); ++i) EXPECT_EQ(odd.scans[i].cloud.points, clean.scans[i].cloud.points);
  EXPECT_EQ(odd.quirks.count("Hesai packets of another model (PandarQT128, expected PandarXT32) skipped"), 1u);
  EXPECT_EQ(odd.quirks.count("Hesai datagrams shorter than a PandarXT32 data packet (1076 bytes; truncated) skipped"), 1u)
      << odd.quirks.summary();
}

TEST(HesaiTolerant, AnotherModelThanConfiguredIsReportedAndAFileOfItRefused) {
  ScanSourceOptions o;
  o.sensor = "PandarXT32";
  const fs::path bag = test::sharedData("sensors/hesai-qt128/1730273789074637152");
  const std::string e = test::errorOf([&] {
    const auto scans = openScanSource(bag, o);
    while (scans->next()) {
    }
  });
  EXPECT_NE(e.find("no decodable LiDAR packet: 1800 × Hesai packets of another model (PandarQT128, expected "
                   "PandarXT32) skipped"),
            std::string::npos)
      << e;
  o.sensor = "PandarXT64";
  EXPECT_NE(test::errorOf([&] { openScanSource(bag, o); }).find("--sensor: 'PandarXT64' is no Hesai model"),
            std::string::npos);
}

// --- The recording paths: capture (UDP 2368), bag, CLI ---------------------------------------

TEST(HesaiCapture, ACaptureDecodesAsTheBag) {
  const fs::path bag = test::sharedData("sensors/hesai-xt32/1673400677802009732");
  std::vector<test::pcap::Record> records;
  std::uint16_t id = 0;
  for (const auto& m : loadMessages(bag.parent_path()))
    for (const Packet& p : m.packets) {
      const auto ip = test::pcap::ipv4Packets(test::pcap::udpSegment(p.data, 10000, kHesaiDataPort), id++, 1500);
      const auto ns = static_cast<std::int64_t>(std::llround(p.stamp * 1e9));
      records.push_back({static_cast<std::uint32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000),
                         test::pcap::ethernet(ip[0], false, false)});
    }
  const fs::path pcap = test::pcap::writeFile(test::scratchDir() / "xt32.pcap", test::pcap::pcapFile(1, true, records));
  const auto from_bag = openScanSource(bag), from_pcap = openScanSource(pcap);
  std::size_t n = 0;
  for (std::optional<Scan> a, b; (a = from_bag->next()) && (b = from_pcap->next()); ++n) {
    EXPECT_EQ(a->cloud.points, b->cloud.points) << n;
    EXPECT_NEAR(a->stamp, b->stamp, 1e-6);
  }
  EXPECT_EQ(n, 4u);
  EXPECT_NE(from_pcap->describe().find("Hesai PandarXT32"), std::string::npos) << from_pcap->describe();
  const auto info = test::runCli("info " + pcap.string() + " --hesai-calibration " +
                                 fileWithExtension(bag.parent_path(), ".csv").string());
  EXPECT_EQ(info.exit_code, 0) << info.output;
  EXPECT_NE(info.output.find("Hesai PandarXT32 (last+strongest dual return), " +
                             fileWithExtension(bag.parent_path(), ".csv").string() + " angle corrections"),
            std::string::npos)
      << info.output;
}

}  // namespace
}  // namespace hazmap
