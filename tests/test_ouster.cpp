// Ouster metadata + packet decoder: the real OS-1-128 (RNG15 low-bandwidth profile) and OS-1-64
// (legacy) captures, packets built here by hand from the firmware manual's layout for the RNG19
// single and dual return profiles, and the metadata layouts.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "pcap_builder.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr double kDeg = std::numbers::pi / 180.0;

const std::filesystem::path kOs128Dir = "sensors/ouster-os1-128";
std::filesystem::path os128Json() { return test::sharedData(kOs128Dir / "OS-1-128_v2.3.0_1024x10.json"); }
std::filesystem::path os128Pcap() { return test::sharedData(kOs128Dir / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"); }
std::filesystem::path os64Json() { return test::sharedData("sensors/ouster-os1-64/ouster_example.json"); }
std::filesystem::path os64Pcap() { return test::sharedData("sensors/ouster-os1-64/ouster_example.pcap"); }

std::string readText(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// All scans of a capture, and the lidar payloads themselves.
struct Decoded {
  std::vector<DecodedScan> scans;
  std::vector<Bytes> packets;
  OusterDecoderStats stats;
};

Decoded decodeCapture(const std::filesystem::path& pcap, const OusterMetadata& meta,
                      OusterDecoderOptions options = {}) {
  Decoded d;
  OusterDecoder decoder(meta, options);
  PcapReader reader(pcap);
  UdpPacket p;
  while (reader.next(p)) {
    if (p.destination_port == 7502) d.packets.emplace_back(p.payload.begin(), p.payload.end());
    decoder.addPacket(p.payload, p.time, pcap.string());
    while (auto s = decoder.takeScan()) d.scans.push_back(std::move(*s));
  }
  if (auto s = decoder.flush()) d.scans.push_back(std::move(*s));
  d.stats = decoder.stats();
  return d;
}

/// The sensor manual's per-pixel formula, written out in double precision (not the look-up
/// table the decoder uses): x = (r − n)·cos(θe + θa)·cos φ + n·cos θe, y likewise with sin,
/// z = (r − n)·sin φ, then lidar_to_sensor_transform; mm → m.
Eigen::Vector3d manualXyz(const OusterMetadata& m, std::uint32_t range_mm, std::size_t column, std::size_t row) {
  const double n = m.lidar_origin_to_beam_origin_mm;
  const double encoder = 2.0 * std::numbers::pi * (1.0 - static_cast<double>(column) / m.columns_per_frame);
  const double azimuth = -m.beam_azimuth_deg[row] * kDeg;
  const double altitude = m.beam_altitude_deg[row] * kDeg;
  const double r = range_mm;
  const Eigen::Vector4d lidar((r - n) * std::cos(encoder + azimuth) * std::cos(altitude) + n * std::cos(encoder),
                              (r - n) * std::sin(encoder + azimuth) * std::cos(altitude) + n * std::sin(encoder),
                              (r - n) * std::sin(altitude), 1.0);
  return (m.lidar_to_sensor * lidar).head<3>() * 0.001;
}

// ---- metadata ---------------------------------------------------------------------------

TEST(OusterMetadata, FlatLayoutOfFirmware23) {
  const OusterMetadata m = readOusterMetadata(os128Json());
  EXPECT_FALSE(m.nested_layout);
  EXPECT_EQ(m.prod_line, "OS-1-128");
  EXPECT_EQ(m.firmware, "v2.3.0");
  EXPECT_EQ(m.serial, "122201000998");
  EXPECT_EQ(m.initialization_id, 7109750u);
  EXPECT_EQ(m.lidar_mode, "1024x10");
  EXPECT_EQ(m.columns_per_frame, 1024u);
  EXPECT_EQ(m.scan_rate_hz, 10.0);
  EXPECT_EQ(m.pixels_per_column, 128u);
  EXPECT_EQ(m.columns_per_packet, 16u);
  EXPECT_EQ(m.profile, OusterProfile::Rng15Rfl8Nir8);
  EXPECT_EQ(m.columnsInWindow(), 1024u);
  EXPECT_EQ(m.lidarPacketSize(), 8448u);
  EXPECT_EQ(m.udp_port_lidar, 7502);
  EXPECT_EQ(m.udp_port_imu, 7503);
  EXPECT_DOUBLE_EQ(m.beam_altitude_deg[0], 20.95);
  EXPECT_DOUBLE_EQ(m.beam_azimuth_deg[3], -4.22);
  EXPECT_DOUBLE_EQ(m.lidar_origin_to_beam_origin_mm, 15.806);
  EXPECT_DOUBLE_EQ(m.beam_to_lidar(0, 3), 15.806);  // built from the beam origin: absent in fw 2.3
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor(0, 0), -1.0);
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor(2, 3), 36.18);
  EXPECT_DOUBLE_EQ(m.imu_to_sensor(1, 3), -11.775);
  EXPECT_EQ(m.pixel_shift_by_row.size(), 128u);
  EXPECT_EQ(m.pixel_shift_by_row[0], 24);
}

TEST(OusterMetadata, OldestLayoutGetsTheDocumentedDefaults) {
  const OusterMetadata m = readOusterMetadata(os64Json());  // only beam angles and lidar_mode
  EXPECT_EQ(m.pixels_per_column, 64u);
  EXPECT_EQ(m.columns_per_frame, 1024u);
  EXPECT_EQ(m.profile, OusterProfile::Legacy);
  EXPECT_EQ(m.lidarPacketSize(), 12608u);
  EXPECT_DOUBLE_EQ(m.lidar_origin_to_beam_origin_mm, 12.163);  // first-generation OS-1
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor(1, 1), -1.0);
  EXPECT_DOUBLE_EQ(m.lidar_to_sensor(2, 3), 36.18);
  EXPECT_EQ(m.udp_port_lidar, 0);
}

/// The OS-1-128 metadata rewritten in the nested layout of firmware ≥ 2.4.
nlohmann::json nestedFromFlat(const nlohmann::json& f) {
  nlohmann::json n;
  n["sensor_info"] = {{"prod_line", f["prod_line"]}, {"build_rev", f["build_rev"]},
                      {"prod_sn", f["prod_sn"]}, {"initialization_id", f["initialization_id"]}};
  n["beam_intrinsics"] = {{"beam_altitude_angles", f["beam_altitude_angles"]},
                          {"beam_azimuth_angles", f["beam_azimuth_angles"]},
                          {"lidar_origin_to_beam_origin_mm", f["lidar_origin_to_beam_origin_mm"]},
                          {"beam_to_lidar_transform", {1, 0, 0, 15.806, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}};
  n["lidar_intrinsics"] = {{"lidar_to_sensor_transform", f["lidar_to_sensor_transform"]}};
  n["imu_intrinsics"] = {{"imu_to_sensor_transform", f["imu_to_sensor_transform"]}};
  n["lidar_data_format"] = f["data_format"];
  n["config_params"] = {{"lidar_mode", f["lidar_mode"]}, {"udp_port_lidar", 7502}, {"udp_port_imu", 7503}};
  return n;
}

TEST(OusterMetadata, NestedLayoutReadsTheSameSensor) {
  const auto flat_json = nlohmann::json::parse(readText(os128Json()));
  const OusterMetadata flat = parseOusterMetadata(flat_json.dump(), "flat");
  const OusterMetadata nested = parseOusterMetadata(nestedFromFlat(flat_json).dump(), "nested");
  EXPECT_TRUE(nested.nested_layout);
  EXPECT_EQ(nested.prod_line, flat.prod_line);
  EXPECT_EQ(nested.serial, flat.serial);
  EXPECT_EQ(nested.initialization_id, flat.initialization_id);
  EXPECT_EQ(nested.columns_per_frame, flat.columns_per_frame);
  EXPECT_EQ(nested.pixels_per_column, flat.pixels_per_column);
  EXPECT_EQ(nested.profile, flat.profile);
  EXPECT_EQ(nested.beam_altitude_deg, flat.beam_altitude_deg);
  EXPECT_EQ(nested.beam_azimuth_deg, flat.beam_azimuth_deg);
  EXPECT_EQ(nested.beam_to_lidar, flat.beam_to_lidar);
  EXPECT_EQ(nested.lidar_to_sensor, flat.lidar_to_sensor);
  EXPECT_EQ(nested.imu_to_sensor, flat.imu_to_sensor);
  EXPECT_EQ(nested.pixel_shift_by_row, flat.pixel_shift_by_row);
  EXPECT_EQ(nested.udp_port_lidar, 7502);
  // A recorder that left the profile and the mode out of the data format: the configuration
  // and the data format's fps say them.
  auto sparse = nestedFromFlat(flat_json);
  sparse["lidar_data_format"].erase("udp_profile_lidar");
  sparse["config_params"].erase("lidar_mode");
  sparse["config_params"]["udp_profile_lidar"] = "RNG15_RFL8_NIR8";
  sparse["lidar_data_format"]["columns_per_frame"] = 1024;
  sparse["lidar_data_format"]["fps"] = 10;
  const OusterMetadata from_config = parseOusterMetadata(sparse.dump(), "sparse");
  EXPECT_EQ(from_config.profile, OusterProfile::Rng15Rfl8Nir8);
  EXPECT_EQ(from_config.columns_per_frame, 1024u);
  EXPECT_EQ(from_config.scan_rate_hz, 10.0);
  // Both decode the capture to the same points.
  const Decoded a = decodeCapture(os128Pcap(), flat), b = decodeCapture(os128Pcap(), nested);
  ASSERT_EQ(a.scans.size(), b.scans.size());
  EXPECT_EQ(a.scans[0].cloud.points, b.scans[0].cloud.points);
}

TEST(OusterMetadata, BadMetadataFailsNamingTheSource) {
  const auto flat = nlohmann::json::parse(readText(os128Json()));
  auto expectError = [](const std::string& text, const std::string& what) {
    try {
      parseOusterMetadata(text, "meta.json");
      FAIL() << "no error for " << what;
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind("meta.json: ", 0), 0u) << msg;
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
  };
  expectError("{\"beam_altitude_angles\": [1, 2", "not valid JSON");
  expectError("[1, 2]", "must be a JSON object");
  auto without = [&](const char* key) { auto j = flat; j.erase(key); return j.dump(); };
  expectError(without("beam_altitude_angles"), "beam_altitude_angles");
  auto with = [&](const char* key, nlohmann::json v) { auto j = flat; j[key] = v; return j.dump(); };
  expectError(with("lidar_mode", "1000x10"), "lidar_mode '1000x10'");
  expectError(with("lidar_to_sensor_transform", std::vector<double>(16, 1.0)), "not a rigid transform");
  expectError(with("lidar_to_sensor_transform", std::vector<double>(15, 0.0)), "16 numbers");
  auto format = [&](const char* key, nlohmann::json v) { auto j = flat; j["data_format"][key] = v; return j.dump(); };
  expectError(format("udp_profile_lidar", "FUSA_RNG15_RFL8_NIR8_DUAL"), "is not supported");
  expectError(format("pixels_per_column", 64), "does not match the 128 beam angles");
  expectError(format("columns_per_frame", 2048), "does not match lidar_mode");
  expectError(format("column_window", {0, 5000}), "column_window");
  auto angles = flat;
  angles["beam_azimuth_angles"].erase(0);
  expectError(angles.dump(), "equal length");
  try {
    readOusterMetadata("/nonexistent/os.json");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/os.json"), std::string::npos);
  }
}

TEST(OusterMetadata, FoundNextToItsCapture) {
  EXPECT_EQ(findOusterMetadata(os128Pcap()), os128Json());  // longest prefix of "…_lb_n3"
  EXPECT_EQ(findOusterMetadata(os64Pcap()), os64Json());
  EXPECT_FALSE(findOusterMetadata(test::sharedData("sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap")));
  // Of several prefixes the longest wins; a longer name that is not a prefix does not.
  const auto dir = test::scratchDir();
  for (const char* name : {"OS-1.json", "OS-1-128.json", "OS-1-128_run2.json", "OS-1-128_run.txt"})
    std::ofstream(dir / name) << "{}";
  EXPECT_EQ(findOusterMetadata(dir / "OS-1-128_run1.pcap"), dir / "OS-1-128.json");
}

// ---- the real captures ------------------------------------------------------------------

std::size_t nonZeroRanges(const std::vector<Bytes>& packets, std::size_t first, std::size_t count) {
  // RNG15_RFL8_NIR8: 32-byte header, 16 columns of (12-byte header + 128 × 4-byte pixels).
  std::size_t n = 0;
  for (std::size_t p = first; p < first + count; ++p)
    for (std::size_t c = 0; c < 16; ++c)
      for (std::size_t r = 0; r < 128; ++r) {
        const std::uint8_t* px = &packets[p][32 + c * (12 + 128 * 4) + 12 + r * 4];
        n += ((px[0] | px[1] << 8) & 0x7fff) != 0;
      }
  return n;
}

TEST(OusterCapture, Os1_128GivesThreeFullScans) {
  const OusterMetadata meta = readOusterMetadata(os128Json());
  const Decoded d = decodeCapture(os128Pcap(), meta);
  ASSERT_EQ(d.scans.size(), 3u);
  EXPECT_EQ(d.stats.lidar_packets, 192u);
  EXPECT_EQ(d.stats.other_packets, 30u);  // IMU
  EXPECT_EQ(d.stats.foreign_packets, 0u);  // init id and serial match the metadata
  EXPECT_EQ(d.stats.incomplete_scans_dropped, 0u);
  EXPECT_EQ(d.stats.invalid_columns, 0u);
  ASSERT_EQ(d.packets.size(), 192u);
  for (std::size_t i = 0; i < 3; ++i) {
    const DecodedScan& s = d.scans[i];
    // Every pixel with a return, and only those: 128 × 1024 minus the zero ranges, counted
    // here straight from the packet bytes.
    EXPECT_EQ(s.cloud.size(), nonZeroRanges(d.packets, i * 64, 64)) << "scan " << i;
    EXPECT_GT(s.cloud.size(), 128u * 1024u / 2);
    EXPECT_LE(s.cloud.size(), 128u * 1024u);
    s.cloud.checkConsistent("scan");
    ASSERT_EQ(s.ring.size(), s.cloud.size());
    ASSERT_EQ(s.return_type.size(), s.cloud.size());
    EXPECT_EQ(*std::max_element(s.ring.begin(), s.ring.end()), 127);
    // Times: the columns' timestamps over one rotation (0.1 s at 10 Hz), on the capture clock
    // (the sensor's clock counted from its boot).
    const auto [tmin, tmax] = std::minmax_element(s.cloud.timestamps.begin(), s.cloud.timestamps.end());
    EXPECT_DOUBLE_EQ(s.stamp, *tmin);
    EXPECT_NEAR(*tmax - *tmin, 0.1 * 1023 / 1024, 2e-3);
    EXPECT_NEAR(s.stamp, 1650410295.35 + 0.1 * static_cast<double>(i), 0.2);
    EXPECT_TRUE(std::is_sorted(s.cloud.timestamps.begin(), s.cloud.timestamps.end()));
  }
  EXPECT_NEAR(d.scans[1].stamp - d.scans[0].stamp, 0.1, 2e-3);
}

TEST(OusterCapture, Os1_128SensorClockMatchesTheSdksRecording) {
  // ouster-sdk's own OSF recording of this capture (its reader test) starts at 991587364520 ns
  // and ends at 991787323080 ns of the sensor's clock: the first and the last scan's first column.
  OusterDecoderOptions sensor_clock;
  sensor_clock.clock = OusterDecoderOptions::Clock::Sensor;
  const Decoded d = decodeCapture(os128Pcap(), readOusterMetadata(os128Json()), sensor_clock);
  ASSERT_EQ(d.scans.size(), 3u);
  EXPECT_DOUBLE_EQ(d.scans[0].stamp, 991587364520e-9);
  EXPECT_DOUBLE_EQ(d.scans[2].stamp, 991787323080e-9);
  // The capture clock (the default for a sensor on its internal clock) only shifts them.
  const Decoded host = decodeCapture(os128Pcap(), readOusterMetadata(os128Json()));
  for (std::size_t i = 0; i < 3; ++i) {
    const double shift = host.scans[i].stamp - d.scans[i].stamp;
    EXPECT_NEAR(host.scans[i].cloud.timestamps.back() - d.scans[i].cloud.timestamps.back(), shift, 1e-6);
  }
}

TEST(OusterCapture, Os1_128PointsMatchTheManualsFormula) {
  const OusterMetadata meta = readOusterMetadata(os128Json());
  const Decoded d = decodeCapture(os128Pcap(), meta);
  ASSERT_EQ(d.scans.size(), 3u);
  // Walk the first scan's packets in the decoder's order (column, then row) and compare every
  // 97th point with the manual's formula.
  const DecodedScan& s = d.scans[0];
  std::size_t k = 0, checked = 0;
  double worst = 0.0;
  for (std::size_t p = 0; p < 64; ++p)
    for (std::size_t c = 0; c < 16; ++c) {
      const std::uint8_t* col = &d.packets[p][32 + c * (12 + 128 * 4)];
      const std::size_t m_id = col[8] | col[9] << 8;
      for (std::size_t r = 0; r < 128; ++r) {
        const std::uint32_t range = ((col[12 + r * 4] | col[13 + r * 4] << 8) & 0x7fffu) * 8u;
        if (range == 0) continue;
        if (k % 97 == 0) {
          const Eigen::Vector3d expect = manualXyz(meta, range, m_id, r);
          worst = std::max(worst, (s.cloud.points[k].cast<double>() - expect).norm());
          EXPECT_EQ(s.ring[k], r);
          EXPECT_EQ(s.cloud.intensity[k], col[12 + r * 4 + 2]);  // RNG15 has no signal: reflectivity
          ++checked;
        }
        ++k;
      }
    }
  EXPECT_EQ(k, s.cloud.size());
  EXPECT_GT(checked, 500u);
  EXPECT_LT(worst, 1e-5);  // float points, 10 µm
}

/// Least-squares plane through points: unit normal n and offset d with n·p = d.
std::pair<Eigen::Vector3d, double> fitPlane(const std::vector<Eigen::Vector3d>& pts) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d n = es.eigenvectors().col(0);
  return {n, n.dot(mean)};
}

TEST(OusterCapture, Os1_128GeometryIsPlausible) {
  const Decoded d = decodeCapture(os128Pcap(), readOusterMetadata(os128Json()));
  ASSERT_EQ(d.scans.size(), 3u);
  const LabeledCloud& c = d.scans[0].cloud;
  std::vector<double> ranges;
  for (const auto& p : c.points) ranges.push_back(p.norm());
  std::sort(ranges.begin(), ranges.end());
  EXPECT_GT(ranges.front(), 0.0);
  // The OS-1's rated range is 120 m; a few returns beyond it (up to 217 m here) are real.
  EXPECT_LT(ranges[ranges.size() * 999 / 1000], 120.0);
  EXPECT_GT(ranges[ranges.size() / 2], 2.0);
  EXPECT_LT(ranges[ranges.size() / 2], 60.0);
  // The ground: points of the lowest beams (30°–10° below the horizon) within 8 m lie on one
  // level plane below the sensor.
  std::vector<Eigen::Vector3d> low;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const Eigen::Vector3d p = c.points[i].cast<double>();
    if (d.scans[0].ring[i] >= 100 && p.head<2>().norm() < 8.0) low.push_back(p);
  }
  ASSERT_GT(low.size(), 5000u);
  // Median height of those points, then a plane through the points near it.
  std::vector<double> z;
  for (const auto& p : low) z.push_back(p.z());
  std::nth_element(z.begin(), z.begin() + static_cast<long>(z.size() / 2), z.end());
  const double ground_z = z[z.size() / 2];
  std::vector<Eigen::Vector3d> ground;
  for (const auto& p : low)
    if (std::abs(p.z() - ground_z) < 0.15) ground.push_back(p);
  EXPECT_GT(ground.size(), low.size() / 2);
  const auto [normal, offset] = fitPlane(ground);
  std::printf("OS-1-128 ground: %zu of %zu low points, normal (%.3f %.3f %.3f), %.3f m below the sensor\n",
              ground.size(), low.size(), normal.x(), normal.y(), normal.z(), std::abs(offset));
  EXPECT_GT(std::abs(normal.z()), 0.99);          // level
  EXPECT_GT(std::abs(offset), 0.3);               // below the sensor …
  EXPECT_LT(std::abs(offset), 3.0);               // … by a vehicle's or a person's height
  EXPECT_LT(ground_z, 0.0);
}

TEST(OusterCapture, Os1_128ScanToScanMotionMatchesTheSdksPoses) {
  // ouster-sdk's own SLAM estimated the capture's three sensor poses (_poses_kitti.txt): ICP of
  // our decoded scans must find the same motion — a mirrored or rotated decoding would not.
  const Decoded d = decodeCapture(os128Pcap(), readOusterMetadata(os128Json()));
  ASSERT_EQ(d.scans.size(), 3u);
  std::ifstream in(test::sharedData(kOs128Dir / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"));
  std::vector<Eigen::Isometry3d> poses;
  for (std::string line; std::getline(in, line);) {
    std::istringstream s(line);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 4; ++col) s >> T.matrix()(r, col);
    poses.push_back(T);
  }
  ASSERT_EQ(poses.size(), 3u);
  const ClassTable table = ClassTable::defaults();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.3;
  RegistrationConfig cfg;
  cfg.use_classes = false;
  cfg.max_iterations = 100;
  for (std::size_t i = 1; i < 3; ++i) {
    const Eigen::Isometry3d expected = poses[i - 1].inverse() * poses[i];  // T_{i-1}_i
    const auto r = registerScans(d.scans[i].cloud, d.scans[i - 1].cloud, Eigen::Isometry3d::Identity(), table, vd, cfg);
    const Eigen::Isometry3d diff = expected.inverse() * r.transform;
    std::printf("scan %zu→%zu: ICP t = (%.3f %.3f %.3f), SDK t = (%.3f %.3f %.3f), diff %.3f m %.3f°\n", i, i - 1,
                r.transform.translation().x(), r.transform.translation().y(), r.transform.translation().z(),
                expected.translation().x(), expected.translation().y(), expected.translation().z(),
                diff.translation().norm(), rotationAngle(diff) / kDeg);
    EXPECT_TRUE(r.converged) << r.reason;
    EXPECT_LT(diff.translation().norm(), 0.05);
    EXPECT_LT(rotationAngle(diff) / kDeg, 0.5);
  }
}

TEST(OusterCapture, Os1_64LegacyCapture) {
  const OusterMetadata meta = readOusterMetadata(os64Json());
  const Decoded d = decodeCapture(os64Pcap(), meta);
  EXPECT_EQ(d.stats.lidar_packets, 100u);
  // 100 packets of 16 columns: 1,600 columns, the end of one rotation, a full one, the start of
  // the next.
  std::printf("OS-1-64: %llu scans emitted, %llu incomplete dropped, %llu invalid columns\n",
              static_cast<unsigned long long>(d.stats.scans_emitted),
              static_cast<unsigned long long>(d.stats.incomplete_scans_dropped),
              static_cast<unsigned long long>(d.stats.invalid_columns));
  ASSERT_EQ(d.scans.size(), 1u);
  EXPECT_EQ(d.stats.incomplete_scans_dropped, 2u);
  const DecodedScan& s = d.scans[0];
  EXPECT_GT(s.cloud.size(), 64u * 1024u / 3);
  EXPECT_LE(s.cloud.size(), 64u * 1024u);
  EXPECT_EQ(*std::max_element(s.ring.begin(), s.ring.end()), 63);
  // Legacy packets carry signal: intensity is not the reflectivity field here.
  const auto [tmin, tmax] = std::minmax_element(s.cloud.timestamps.begin(), s.cloud.timestamps.end());
  EXPECT_NEAR(*tmax - *tmin, 0.1 * 1023 / 1024, 2e-3);
  std::vector<double> ranges;
  for (const auto& p : s.cloud.points) ranges.push_back(p.norm());
  std::sort(ranges.begin(), ranges.end());
  EXPECT_GT(ranges[ranges.size() / 2], 1.0);
  EXPECT_LT(ranges[ranges.size() * 999 / 1000], 120.0);
  // Keeping incomplete scans also gives the partial rotations before and after.
  OusterDecoderOptions keep;
  keep.keep_incomplete_scans = true;
  const Decoded all = decodeCapture(os64Pcap(), meta, keep);
  ASSERT_EQ(all.scans.size(), 3u);
  EXPECT_EQ(all.scans[1].cloud.points, s.cloud.points);
  EXPECT_LT(all.scans[0].cloud.size() + all.scans[2].cloud.size(), 64u * (1600 - 1024));
}

TEST(OusterBag, Os0_128RosBagDecodesItsScanWithTheMetadataTopic) {
  // The ouster_ros driver's ROS 1 bag: raw packets (ouster_ros/PacketMsg) and the sensor's
  // metadata JSON on its own topic (std_msgs/String).
  const auto path = test::sharedData("sensors/ouster-os0-128-ros1/512x10_raw.bag");
  auto bag = openBag(path);
  std::string json;
  std::vector<std::pair<double, Bytes>> packets;
  BagMessage msg;
  while (bag->next(msg)) {
    if (msg.topic->name == "/os_node0/metadata") json = decodeString(msg.data, msg.topic->serialization, path.string());
    if (msg.topic->name == "/os_node0/lidar_packets" || msg.topic->name == "/os_node0/imu_packets")
      packets.emplace_back(static_cast<double>(msg.log_time_ns) * 1e-9,
                           decodeOusterPacket(msg.data, msg.topic->serialization, path.string()).data);
  }
  ASSERT_FALSE(json.empty());
  const OusterMetadata meta = parseOusterMetadata(json, path.string() + " /os_node0/metadata");
  EXPECT_TRUE(meta.nested_layout);
  EXPECT_EQ(meta.prod_line, "OS-0-128");
  EXPECT_EQ(meta.columns_per_frame, 512u);
  EXPECT_EQ(meta.pixels_per_column, 128u);
  EXPECT_EQ(meta.profile, OusterProfile::Rng15Rfl8Nir8);
  OusterDecoder decoder(meta);
  std::vector<DecodedScan> scans;
  std::vector<Bytes> lidar;
  for (const auto& [time, data] : packets) {
    if (data.size() == meta.lidarPacketSize()) lidar.push_back(data);
    decoder.addPacket(data, time, path.string());
    while (auto s = decoder.takeScan()) scans.push_back(std::move(*s));
  }
  if (auto s = decoder.flush()) scans.push_back(std::move(*s));
  const OusterDecoderStats& st = decoder.stats();
  std::printf("OS-0-128 bag: %zu lidar packets, %llu scans, %llu incomplete dropped, %llu foreign, %llu late\n",
              lidar.size(), static_cast<unsigned long long>(st.scans_emitted),
              static_cast<unsigned long long>(st.incomplete_scans_dropped),
              static_cast<unsigned long long>(st.foreign_packets), static_cast<unsigned long long>(st.late_packets));
  EXPECT_EQ(st.foreign_packets, 0u);
  ASSERT_EQ(scans.size(), 1u);
  const DecodedScan& s = scans[0];
  // The bag holds exactly one rotation: 32 packets of 16 columns, all of one frame id.
  ASSERT_EQ(lidar.size(), 32u);
  std::size_t returns = 0;
  for (const Bytes& p : lidar) {
    EXPECT_EQ(p[2] | p[3] << 8, lidar[0][2] | lidar[0][3] << 8);
    for (std::size_t c = 0; c < 16; ++c)
      for (std::size_t r = 0; r < 128; ++r) {
        const std::uint8_t* px = &p[32 + c * (12 + 128 * 4) + 12 + r * 4];
        returns += ((px[0] | px[1] << 8) & 0x7fff) != 0;
      }
  }
  // Every return of the rotation (counted here from the bytes), no more: 44 % of the pixels.
  EXPECT_EQ(s.cloud.size(), returns);
  EXPECT_GT(s.cloud.size(), 128u * 512u / 3);
  EXPECT_EQ(*std::max_element(s.ring.begin(), s.ring.end()), 127);
  const auto [tmin, tmax] = std::minmax_element(s.cloud.timestamps.begin(), s.cloud.timestamps.end());
  EXPECT_NEAR(*tmax - *tmin, 0.1 * 511 / 512, 2e-3);
  // An OS-0 sees ±45°: points well above and below the horizon.
  float zmin = 0, zmax = 0;
  for (std::size_t i = 0; i < s.cloud.size(); ++i) {
    const auto& p = s.cloud.points[i];
    const float elevation = std::atan2(p.z() - 0.036f, p.head<2>().norm()) / static_cast<float>(kDeg);
    zmin = std::min(zmin, elevation), zmax = std::max(zmax, elevation);
  }
  EXPECT_LT(zmin, -40.0f);
  EXPECT_GT(zmax, 40.0f);
}

TEST(OusterCapture, Os1_64FragmentedAtTheMtuDecodesTheSame) {
  // A legacy OS-1-64 packet (12,608 bytes) crosses a 1,500-byte MTU as 9 IPv4 fragments: the
  // OS-1-64 capture re-sent that way decodes to the same scans, point for point.
  namespace pc = test::pcap;
  const OusterMetadata meta = readOusterMetadata(os64Json());
  const Decoded direct = decodeCapture(os64Pcap(), meta);
  std::vector<pc::Record> records;
  PcapReader reader(os64Pcap());
  UdpPacket p;
  std::uint16_t id = 0;
  while (reader.next(p)) {
    const Bytes payload(p.payload.begin(), p.payload.end());
    const auto sec = static_cast<std::uint32_t>(p.time_ns / 1'000'000'000), usec = static_cast<std::uint32_t>(p.time_ns % 1'000'000'000 / 1000);
    for (const Bytes& ip : pc::ipv4Packets(pc::udpSegment(payload, p.source_port, p.destination_port), id++, 1500))
      records.push_back({sec, usec, pc::ethernet(ip, false, false)});
  }
  EXPECT_EQ(records.size(), 900u);
  const auto path = pc::writeFile(test::scratchDir() / "os1-64-fragmented.pcap", pc::pcapFile(1, false, records));
  const Decoded fragmented = decodeCapture(path, meta);
  ASSERT_EQ(fragmented.scans.size(), direct.scans.size());
  EXPECT_EQ(fragmented.packets, direct.packets);
  EXPECT_EQ(fragmented.scans[0].cloud.points, direct.scans[0].cloud.points);
  EXPECT_EQ(fragmented.scans[0].cloud.timestamps, direct.scans[0].cloud.timestamps);
}

// ---- packets built by hand --------------------------------------------------------------

/// A small sensor: 8 beams, 512 columns, 4 columns per packet, in the nested metadata layout.
OusterMetadata smallSensor(const std::string& profile) {
  nlohmann::json j;
  std::vector<double> alt, az;
  for (int r = 0; r < 8; ++r) alt.push_back(15.0 - 4.0 * r), az.push_back(r % 2 ? -3.0 : 3.0);
  j["sensor_info"] = {{"prod_line", "OS-0-32"}, {"prod_sn", "992100000123"}, {"initialization_id", 4242}};
  j["beam_intrinsics"] = {{"beam_altitude_angles", alt}, {"beam_azimuth_angles", az},
                          {"lidar_origin_to_beam_origin_mm", 27.67},
                          {"beam_to_lidar_transform", {1, 0, 0, 27.67, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}}};
  // A sensor-frame transform with a yaw as well as the usual offset.
  const double c = std::cos(0.3), s = std::sin(0.3);
  j["lidar_intrinsics"] = {{"lidar_to_sensor_transform", {c, -s, 0, 5, s, c, 0, -7, 0, 0, 1, 36.18, 0, 0, 0, 1}}};
  j["lidar_data_format"] = {{"pixels_per_column", 8}, {"columns_per_packet", 4}, {"columns_per_frame", 512},
                            {"column_window", {0, 511}}, {"udp_profile_lidar", profile}};
  j["config_params"] = {{"lidar_mode", "512x10"}, {"udp_port_lidar", 7502}};
  return parseOusterMetadata(j.dump(), "small.json");
}

struct PixelSpec {
  std::uint32_t range = 0, range2 = 0;
  std::uint16_t signal = 0, signal2 = 0;
  std::uint8_t reflectivity = 0, reflectivity2 = 0;
};

template <typename T>
void put(Bytes& b, std::size_t at, T v) { std::memcpy(&b[at], &v, sizeof v); }

/// One packet of `m`'s profile: columns first_column … + columns_per_packet − 1.
Bytes makePacket(const OusterMetadata& m, std::uint16_t frame_id, std::uint16_t first_column,
                 std::uint64_t first_ts_ns, const std::function<PixelSpec(std::size_t, std::size_t)>& pixel,
                 const std::function<bool(std::size_t)>& valid = [](std::size_t) { return true; }) {
  const bool legacy = m.profile == OusterProfile::Legacy;
  const bool dual = m.profile == OusterProfile::Rng19Rfl8Sig16Nir16Dual;
  const std::size_t px_size = dual ? 16 : 12, head = legacy ? 0 : 32, col_head = legacy ? 16 : 12;
  const std::size_t col_size = col_head + m.pixels_per_column * px_size + (legacy ? 4 : 0);
  Bytes b(m.lidarPacketSize(), 0);
  if (!legacy) {
    put<std::uint16_t>(b, 0, 1);  // lidar packet
    put<std::uint16_t>(b, 2, frame_id);
    put<std::uint32_t>(b, 4, static_cast<std::uint32_t>(m.initialization_id));  // 24 bits + serial's first byte
    const std::uint64_t sn = std::stoull(m.serial);
    for (int i = 0; i < 5; ++i) b[7 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(sn >> (8 * i));
  }
  for (std::size_t c = 0; c < m.columns_per_packet; ++c) {
    const std::size_t col = head + c * col_size;
    const std::size_t m_id = first_column + c;
    put<std::uint64_t>(b, col, first_ts_ns + c * 97'656);  // 100 ms / 1024 columns
    put<std::uint16_t>(b, col + 8, static_cast<std::uint16_t>(m_id));
    if (legacy) {
      put<std::uint16_t>(b, col + 10, frame_id);
      put<std::uint32_t>(b, col + 12, static_cast<std::uint32_t>(m_id * 90112 / m.columns_per_frame));
      put<std::uint32_t>(b, col + col_size - 4, valid(m_id) ? 0xffffffffu : 0u);
    } else {
      put<std::uint16_t>(b, col + 10, valid(m_id) ? 1 : 0);
    }
    for (std::size_t r = 0; r < m.pixels_per_column; ++r) {
      const PixelSpec p = pixel(m_id, r);
      const std::size_t px = col + col_head + r * px_size;
      if (legacy) {
        put<std::uint32_t>(b, px, p.range);
        put<std::uint16_t>(b, px + 4, p.reflectivity);
        put<std::uint16_t>(b, px + 6, p.signal);
      } else if (dual) {
        put<std::uint32_t>(b, px, p.range | std::uint32_t{p.reflectivity} << 24);
        put<std::uint32_t>(b, px + 4, p.range2 | std::uint32_t{p.reflectivity2} << 24);
        put<std::uint16_t>(b, px + 8, p.signal);
        put<std::uint16_t>(b, px + 10, p.signal2);
      } else {
        put<std::uint32_t>(b, px, p.range | 0xa0000000u);  // flag bits above the 19-bit range
        b[px + 4] = p.reflectivity;
        put<std::uint16_t>(b, px + 6, p.signal);
      }
    }
  }
  return b;
}

/// Points are float: a few units in the last place of the coordinate (ranges here reach 524 m).
double floatTolerance(std::uint32_t range_mm) { return 1e-6 + 3e-7 * range_mm * 1e-3; }

/// Point k of `s` is the return of `range` mm at column c, beam r, with its signal and return type.
void expectReturn(const DecodedScan& s, std::size_t k, const OusterMetadata& m, std::uint32_t range, std::size_t c,
                  std::size_t r, std::uint16_t signal, std::uint8_t return_type) {
  ASSERT_LT(k, s.cloud.size());
  EXPECT_LT((s.cloud.points[k].cast<double>() - manualXyz(m, range, c, r)).norm(), floatTolerance(range)) << c << "," << r;
  EXPECT_EQ(s.cloud.intensity[k], signal) << c << "," << r;
  EXPECT_EQ(s.return_type[k], return_type) << c << "," << r;
}

PixelSpec pattern(std::size_t column, std::size_t row) {
  PixelSpec p;
  // Zero ranges (no return) on a diagonal; up to 2^19 − 1 mm (the 19-bit field's maximum).
  p.range = (column + row) % 7 == 0 ? 0 : static_cast<std::uint32_t>(1000 + 997 * column + 13 * row) % 524287;
  p.range2 = (column * 3 + row) % 5 == 0 ? 0 : p.range + 2500;
  p.signal = static_cast<std::uint16_t>(100 + row);
  p.signal2 = static_cast<std::uint16_t>(50 + row);
  p.reflectivity = static_cast<std::uint8_t>(column % 256);
  p.reflectivity2 = static_cast<std::uint8_t>(row);
  return p;
}

/// Feeds frames [0, frames) of a sensor, all columns, then flushes.
std::vector<DecodedScan> feedFrames(OusterDecoder& decoder, const OusterMetadata& m, int frames,
                                    const std::function<bool(std::size_t)>& valid = [](std::size_t) { return true; }) {
  std::vector<DecodedScan> scans;
  const std::uint64_t t0 = 1'700'000'000'000'000'000ull;  // PTP time: used as it is
  for (int f = 0; f < frames; ++f)
    for (std::size_t c = 0; c < m.columns_per_frame; c += m.columns_per_packet) {
      const Bytes b = makePacket(m, static_cast<std::uint16_t>(f + 100), static_cast<std::uint16_t>(c),
                                 t0 + static_cast<std::uint64_t>(f) * 100'000'000ull + c * 97'656, pattern, valid);
      decoder.addPacket(b, 0.0, "hand.pcap");
      while (auto s = decoder.takeScan()) scans.push_back(std::move(*s));
    }
  if (auto s = decoder.flush()) scans.push_back(std::move(*s));
  return scans;
}

TEST(OusterPackets, Rng19SingleReturnHandComputed) {
  const OusterMetadata m = smallSensor("RNG19_RFL8_SIG16_NIR16");
  EXPECT_EQ(m.lidarPacketSize(), 32u + 4u * (12u + 8u * 12u) + 32u);
  OusterDecoder decoder(m);
  const auto scans = feedFrames(decoder, m, 2);
  ASSERT_EQ(scans.size(), 2u);
  const DecodedScan& s = scans[0];
  std::size_t k = 0;
  for (std::size_t c = 0; c < 512; ++c)
    for (std::size_t r = 0; r < 8; ++r) {
      const PixelSpec p = pattern(c, r);
      if (p.range == 0) continue;
      expectReturn(s, k, m, p.range, c, r, p.signal, 0);
      if (k >= s.cloud.size()) return;
      EXPECT_EQ(s.ring[k], r);
      EXPECT_DOUBLE_EQ(s.cloud.timestamps[k], 1.7e9 + static_cast<double>(c * 97'656) * 1e-9);
      ++k;
    }
  EXPECT_EQ(k, s.cloud.size());
  EXPECT_DOUBLE_EQ(s.stamp, 1.7e9);
  // One point worked by hand: column 0 (encoder angle 2π ≡ 0), beam 0 (altitude 15°, azimuth
  // 3° → θa = −3°), range 1000 mm, beam origin 27.67 mm; then the 0.3 rad yaw and offset.
  const double n = 27.67, r = 1000.0;
  const Eigen::Vector3d lidar((r - n) * std::cos(-3 * kDeg) * std::cos(15 * kDeg) + n,
                              (r - n) * std::sin(-3 * kDeg) * std::cos(15 * kDeg), (r - n) * std::sin(15 * kDeg));
  const Eigen::Vector3d sensor = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * lidar +
                                  Eigen::Vector3d(5, -7, 36.18)) * 0.001;
  ASSERT_EQ(pattern(0, 0).range, 0u);  // (0,0) is on the zero diagonal; (0,1) is the first point
  EXPECT_NEAR((s.cloud.points[0].cast<double>() - manualXyz(m, pattern(0, 1).range, 0, 1)).norm(), 0.0, 2e-5);
  EXPECT_NEAR((manualXyz(m, 1000, 0, 0) - sensor).norm(), 0.0, 1e-12);  // the test's formula itself
  // Reflectivity on request.
  OusterDecoderOptions refl;
  refl.intensity = OusterDecoderOptions::Intensity::Reflectivity;
  OusterDecoder by_reflectivity(m, refl);
  const auto r_scans = feedFrames(by_reflectivity, m, 1);
  ASSERT_EQ(r_scans.size(), 1u);
  EXPECT_EQ(r_scans[0].cloud.intensity[0], pattern(0, 1).reflectivity);
}

TEST(OusterPackets, DualReturnGivesBothReturns) {
  const OusterMetadata m = smallSensor("RNG19_RFL8_SIG16_NIR16_DUAL");
  EXPECT_EQ(m.lidarPacketSize(), 32u + 4u * (12u + 8u * 16u) + 32u);
  OusterDecoder decoder(m);
  const auto scans = feedFrames(decoder, m, 1);
  ASSERT_EQ(scans.size(), 1u);
  const DecodedScan& s = scans[0];
  std::size_t k = 0, second = 0;
  for (std::size_t c = 0; c < 512; ++c)
    for (std::size_t r = 0; r < 8; ++r) {
      const PixelSpec p = pattern(c, r);
      if (p.range != 0) expectReturn(s, k++, m, p.range, c, r, p.signal, 0);
      if (p.range2 != 0) expectReturn(s, k++, m, p.range2, c, r, p.signal2, 1), ++second;
    }
  EXPECT_EQ(k, s.cloud.size());
  EXPECT_GT(second, 1000u);
  OusterDecoderOptions first_only;
  first_only.second_return = false;
  OusterDecoder d1(m, first_only);
  EXPECT_EQ(feedFrames(d1, m, 1)[0].cloud.size(), s.cloud.size() - second);
}

TEST(OusterPackets, LegacyHandBuiltAndInvalidColumnsSkipped) {
  auto m = smallSensor("LEGACY");
  OusterDecoder decoder(m);
  // Columns 100–103 flagged invalid (e.g. outside the sensor's azimuth window).
  auto valid = [](std::size_t c) { return c < 100 || c > 103; };
  const auto scans = feedFrames(decoder, m, 1, valid);
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(decoder.stats().invalid_columns, 4u);
  std::size_t expected = 0;
  for (std::size_t c = 0; c < 512; ++c)
    for (std::size_t r = 0; r < 8; ++r) expected += valid(c) && pattern(c, r).range != 0;
  EXPECT_EQ(scans[0].cloud.size(), expected);
  EXPECT_EQ(scans[0].cloud.intensity[0], pattern(0, 1).signal);
}

TEST(OusterPackets, ScansAreCutAtTheFrameIdLatePacketsDroppedIncompleteScansCounted) {
  const OusterMetadata m = smallSensor("RNG19_RFL8_SIG16_NIR16");
  OusterDecoder decoder(m);
  const std::uint64_t t0 = 1'700'000'000'000'000'000ull;
  auto packet = [&](std::uint16_t frame, std::uint16_t column) {
    return makePacket(m, frame, column, t0 + frame * 100'000'000ull + column * 97'656ull, pattern);
  };
  std::vector<DecodedScan> scans;
  auto add = [&](const Bytes& b) {
    decoder.addPacket(b, 0.0, "x");
    while (auto s = decoder.takeScan()) scans.push_back(std::move(*s));
  };
  // Frame 7 from column 256 on (the capture started mid-rotation): incomplete.
  for (std::uint16_t c = 256; c < 512; c += 4) add(packet(7, c));
  EXPECT_TRUE(scans.empty());  // not emitted until the frame id changes
  // Frame 8 complete, with one late packet of frame 7 in the middle; frame id wraps 65535 → 0.
  for (std::uint16_t c = 0; c < 512; c += 4) {
    add(packet(8, c));
    if (c == 40) add(packet(7, 500));
  }
  EXPECT_EQ(decoder.stats().incomplete_scans_dropped, 1u);
  EXPECT_EQ(decoder.stats().late_packets, 1u);
  EXPECT_TRUE(scans.empty());
  add(packet(9, 0));  // the next frame's first packet completes frame 8
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_NEAR(scans[0].stamp, 1.7e9 + 0.8, 1e-6);
  // An IMU packet and a packet of another sensor are ignored.
  add(Bytes(48, 0));
  Bytes other = packet(9, 4);
  other[4] ^= 1;  // initialization id
  add(other);
  EXPECT_EQ(decoder.stats().other_packets, 1u);
  EXPECT_EQ(decoder.stats().foreign_packets, 1u);
  EXPECT_FALSE(decoder.flush().has_value());  // frame 9 incomplete: dropped
  EXPECT_EQ(decoder.stats().incomplete_scans_dropped, 2u);
  EXPECT_EQ(decoder.stats().scans_emitted, 1u);
  const auto notices = decoder.notices("x.pcap");
  ASSERT_EQ(notices.size(), 3u);
  EXPECT_EQ(notices[0], "x.pcap: 2 incomplete Ouster scans dropped (started or ended mid-rotation, or packets lost)");
  EXPECT_NE(notices[1].find("1 Ouster packets arrived after"), std::string::npos);
  EXPECT_NE(notices[2].find("another sensor"), std::string::npos);
}

TEST(OusterPackets, MetadataOfAnotherSensorIsNamed) {
  // The OS-1-64's metadata against the OS-1-128 capture: nothing decodes, and the notice says why.
  const Decoded d = decodeCapture(os128Pcap(), readOusterMetadata(os64Json()));
  EXPECT_TRUE(d.scans.empty());
  OusterDecoder decoder(readOusterMetadata(os64Json()));
  decoder.addPacket(d.packets[0], 0.0, "x");
  const auto notices = decoder.notices("os1-128.pcap");
  ASSERT_EQ(notices.size(), 1u);
  EXPECT_EQ(notices[0], "os1-128.pcap: no packet of Ouster OS 1024x10 LEGACY (64 beams)'s lidar packet size "
                        "(12608 bytes) among 1 packets (the last of 8448 bytes): the metadata does not belong "
                        "to these packets");
}

TEST(OusterPackets, CaptureClockForAnUnsynchronisedSensor) {
  const OusterMetadata m = smallSensor("RNG19_RFL8_SIG16_NIR16");
  OusterDecoder decoder(m);
  // Timestamps from the sensor's boot (internal oscillator): shifted onto the receive time.
  const std::uint64_t boot = 5'000'000'000ull;
  std::optional<DecodedScan> scan;
  for (int f = 0; f < 2; ++f)
    for (std::uint16_t c = 0; c < 512; c += 4) {
      const std::uint64_t ts = boot + f * 100'000'000ull + c * 97'656ull;
      const double receive = 1.6e9 + static_cast<double>(ts + 3 * 97'656) * 1e-9 + 0.0005;  // after its last column
      decoder.addPacket(makePacket(m, static_cast<std::uint16_t>(f), c, ts, pattern), receive, "x");
      if (auto s = decoder.takeScan()) scan = std::move(s);
    }
  ASSERT_TRUE(scan.has_value());
  EXPECT_NEAR(scan->stamp, 1.6e9 + 5.0 + 0.0005, 1e-6);
  EXPECT_NEAR(scan->cloud.timestamps.back() - scan->stamp, 511 * 97'656e-9, 1e-6);
}

TEST(OusterPackets, MeasurementIdBeyondTheFrameIsSkippedAndCounted) {
  const OusterMetadata m = smallSensor("RNG19_RFL8_SIG16_NIR16");
  OusterDecoder decoder(m);
  const Bytes b = makePacket(m, 1, 1020, 0, pattern);  // columns 1020… of a 512-column sensor
  decoder.addPacket(b, 0.0, "wrong-mode.pcap");
  EXPECT_EQ(decoder.quirks().count("Ouster columns with a measurement id beyond the 512-column frame (lidar_mode "
                                   "512x10) skipped"),
            4u);
  EXPECT_FALSE(decoder.flush().has_value());
}

}  // namespace
}  // namespace hazmap
