// The IMU stream (issue 36 part 2): imu.txt (reader errors, round trip, cleaning, spans), Ouster
// IMU packets in the real OS-1-128 capture, and Scan::imu from a sequence folder and a capture.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/io/imu.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/deskew.hpp"
#include "hazmap/preprocess/imu_gravity.hpp"
#include "hazmap/preprocess/imu_motion.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/imu_rotation.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

std::vector<ImuSample> evenSamples(double t0, double rate, std::size_t n) {
  std::vector<ImuSample> out(n);
  for (std::size_t i = 0; i < n; ++i) out[i].time = t0 + static_cast<double>(i) / rate;
  return out;
}

/// `hazmap simulate` of `frames` corridor frames with a 200 Hz IMU, written as an MCAP bag (LiDAR +
/// sensor_msgs/Imu) in the scratch folder.
fs::path simulatedCorridorMcap(const std::string& name, int frames) {
  const fs::path bag = test::scratchDir() / name;
  fs::remove(bag);
  const auto r = test::runCli("simulate --scenario corridor --frames " + std::to_string(frames) +
                              " --imu-rate 200 --format mcap --overwrite --out " + bag.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return bag;
}

fs::path os128Pcap() { return test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap"); }

}  // namespace

TEST(ImuFile, RoundTripIsExact) {
  const fs::path path = test::scratchDir() / "imu_roundtrip.txt";
  std::vector<ImuSample> samples = evenSamples(12.25, 200.0, 50);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    samples[i].gyro = Eigen::Vector3d(0.1 * i, -1e-7 * i, std::sin(i));
    samples[i].accel = Eigen::Vector3d(0.01, 9.80665 + 1e-9 * i, -std::cos(i));
  }
  writeImuFile(path, samples);
  const auto back = readImuFile(path);
  ASSERT_EQ(back.size(), samples.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].time, samples[i].time);
    EXPECT_EQ(back[i].gyro, samples[i].gyro);
    EXPECT_EQ(back[i].accel, samples[i].accel);
  }
}

TEST(ImuFile, BadLinesNameTheFileAndLine) {
  const fs::path path = test::scratchDir() / "imu_bad.txt";
  writeText(path, "# header\n0 0 0 0 0 0 9.8\n0.01 0 0 0 0 9.8\n");
  EXPECT_NE(test::errorOf([&] { readImuFile(path); }).find("imu_bad.txt: line 3"), std::string::npos);
  writeText(path, "0 0 0 nan 0 0 9.8\n");
  EXPECT_NE(test::errorOf([&] { readImuFile(path); }).find("non-finite"), std::string::npos);
  writeText(path, "0 0 0 x 0 0 9.8\n");
  EXPECT_NE(test::errorOf([&] { readImuFile(path); }).find("imu_bad.txt: line 1"), std::string::npos);
  EXPECT_NE(test::errorOf([&] { readImuFile(test::scratchDir() / "no_such_imu.txt"); }).find("no_such_imu.txt"),
            std::string::npos);
}

TEST(ImuStream, OutOfOrderSamplesDroppedAndGapsCounted) {
  std::vector<ImuSample> s = evenSamples(0.0, 100.0, 10);
  s[4].time = s[2].time;         // a duplicate
  s[7].time = s[9].time + 0.5;   // jumps ahead, so 8 and 9 are out of order
  const ImuStreamReport report = cleanImuStream(s, kImuMaxGap);
  EXPECT_EQ(report.out_of_order, 3u);
  EXPECT_EQ(report.gaps, 1u);
  EXPECT_NEAR(report.longest_gap, 0.59 - 0.06, 1e-9);
  for (std::size_t i = 1; i < s.size(); ++i) EXPECT_GT(s[i].time, s[i - 1].time);
  EXPECT_NE(describe(report, "imu.txt").find("imu.txt: 3 IMU samples"), std::string::npos);
  EXPECT_TRUE(describe(ImuStreamReport{}, "imu.txt").empty());
}

TEST(ImuStream, SpanCoversItsEndsOrIsEmpty) {
  const std::vector<ImuSample> s = evenSamples(0.0, 100.0, 101);  // 0 … 1 s
  const auto span = imuSpan(s, 0.305, 0.4);
  ASSERT_FALSE(span.empty());
  EXPECT_LE(span.front().time, 0.305);
  EXPECT_GE(span.back().time, 0.4);
  EXPECT_EQ(span.size(), 11u);  // 0.30 … 0.40
  EXPECT_TRUE(imuSpan(s, -0.1, 0.2).empty());  // starts before the stream
  EXPECT_TRUE(imuSpan(s, 0.9, 1.2).empty());   // ends after it
  std::vector<ImuSample> gap = s;
  gap.erase(gap.begin() + 40, gap.begin() + 50);  // 0.1 s without a sample
  EXPECT_TRUE(imuSpan(gap, 0.3, 0.6).empty());
  EXPECT_FALSE(imuSpan(gap, 0.5, 0.6).empty());
  // Below the scan rate (a sample every 0.2 s): nothing is integrated as measured.
  EXPECT_TRUE(imuSpan(evenSamples(0.0, 5.0, 10), 0.3, 0.4).empty());
}

TEST(OusterImu, RealCaptureSamplesAtTheSensorsRateAndSeeGravity) {
  const OusterMetadata meta = readOusterMetadata(test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10.json"));
  auto source = openScanSource(os128Pcap());
  std::vector<Scan> scans;
  while (auto s = source->next()) scans.push_back(std::move(*s));
  ASSERT_EQ(scans.size(), 3u);
  std::vector<ImuSample> all;
  for (const Scan& scan : scans) {
    const auto [lo, hi] = std::minmax_element(scan.cloud.timestamps.begin(), scan.cloud.timestamps.end());
    if (scan.imu.empty()) continue;
    // The span reaches from the previous scan's stamp (or the first point) to the last point.
    EXPECT_LE(scan.imu.front().time, scan.index == 0 ? *lo : scans[scan.index - 1].stamp);
    EXPECT_GE(scan.imu.back().time, *hi);
    for (const auto& s : scan.imu)
      if (all.empty() || s.time > all.back().time) all.push_back(s);
  }
  // 30 IMU packets over 0.29 s; the first scan starts before the first IMU packet.
  ASSERT_GE(all.size(), 20u);
  const double rate = static_cast<double>(all.size() - 1) / (all.back().time - all.front().time);
  EXPECT_NEAR(rate, 100.0, 5.0);  // the OS-1's IMU rate
  Eigen::Vector3d mean_accel = Eigen::Vector3d::Zero();
  double max_gyro = 0.0;
  for (const auto& s : all) mean_accel += s.accel / static_cast<double>(all.size()), max_gyro = std::max(max_gyro, s.gyro.norm());
  // Hand-held, slowly moving: the mean specific force is gravity, the rotation rate a few °/s.
  EXPECT_NEAR(mean_accel.norm(), 9.81, 1.2);
  EXPECT_LT(max_gyro, 20.0 * M_PI / 180.0);
  EXPECT_GT(max_gyro, 0.0);
  // In the sensor frame: gravity mostly along the sensor's z (the OS-1 stands upright), up.
  EXPECT_GT(mean_accel.z(), 0.8 * mean_accel.norm());
  (void)meta;
}

TEST(OusterImu, PacketDecodingRotatesIntoTheSensorFrame) {
  OusterMetadata meta;
  meta.imu_to_sensor.topLeftCorner<3, 3>() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<std::uint8_t> p(kOusterImuPacketSize, 0);
  const std::uint64_t t = 123456789;
  const float values[6] = {1.0f, 0.0f, 0.0f, 0.0f, 90.0f, 0.0f};  // 1 g along x, 90 °/s about y
  std::memcpy(p.data() + 16, &t, 8);
  std::memcpy(p.data() + 24, values, sizeof values);
  const auto d = decodeOusterImuPacket(p, meta);
  ASSERT_TRUE(d);
  EXPECT_EQ(d->gyro_time_ns, t);
  EXPECT_NEAR((d->sample.accel - Eigen::Vector3d(0, 9.80665, 0)).norm(), 0.0, 1e-6);
  EXPECT_NEAR((d->sample.gyro - Eigen::Vector3d(-M_PI / 2, 0, 0)).norm(), 0.0, 1e-6);
  p.pop_back();
  EXPECT_FALSE(decodeOusterImuPacket(p, meta));
  p.push_back(0);
  const float nan = std::nanf("");
  std::memcpy(p.data() + 40, &nan, 4);
  EXPECT_FALSE(decodeOusterImuPacket(p, meta));
}

// ---------------------------------------------------------------------------------------------
// The simulated IMU (issue 36 part 3).

namespace {

sim::Simulator shortCorridor(double rate_hz, const std::string& preset = "none") {
  sim::SimulatorConfig c;
  c.scenario = "corridor";
  c.max_frames = 40;
  c.imu.rate_hz = rate_hz;
  return sim::Simulator(sim::SimulatorConfig::withPreset(preset, c, "test"));
}

std::vector<double> frameTimes(const sim::Simulator& s) {
  std::vector<double> t;
  for (const auto& r : s.samples()) t.push_back(r.time);
  return t;
}

}  // namespace

TEST(SimImu, GyroIntegratesToTheTrueIncrementsAndNoiseHasTheDatasheetLevel) {
  const sim::Simulator s = shortCorridor(200.0, "worst-day");  // yaw kicks up to 45°
  const auto times = frameTimes(s);
  // The turn-on bias left out here (tracking estimates it online): white noise and random walk.
  sim::ImuConfig unbiased = s.config().imu;
  unbiased.gyro_bias_sigma = 0.0;
  const auto noisy = sim::simulateImuStream(s.worldPoses(), times, unbiased, 1);
  sim::ImuConfig clean = s.config().imu;
  clean.gyro_noise_density = clean.accel_noise_density = clean.gyro_bias_sigma = 0.0;
  clean.gyro_bias_walk = clean.accel_bias_walk = 0.0;
  const auto exact = sim::simulateImuStream(s.worldPoses(), times, clean, 1);
  ASSERT_EQ(noisy.size(), exact.size());
  EXPECT_NEAR(static_cast<double>(noisy.size()), (times.back() - times.front()) * 200.0, 1.5);
  // White noise: σ = density · √rate (BMI088: 0.014 °/s/√Hz → 0.198 °/s at 200 Hz), after the
  // bias (mean) is taken out over a short stretch.
  double sum = 0.0, sum2 = 0.0;
  const std::size_t n = 400;
  for (std::size_t k = 0; k < n; ++k) {
    const double d = noisy[k].gyro.x() - exact[k].gyro.x();
    sum += d, sum2 += d * d;
  }
  const double sd = std::sqrt(sum2 / n - (sum / n) * (sum / n)) * 180.0 / M_PI;
  EXPECT_NEAR(sd, 0.014 * std::sqrt(200.0), 0.03);
  // Integrated between frames, the noise-free gyro gives every true rotation increment (kicks
  // too) in the sensor frame; to 0.02° (a rate that changes at a frame is averaged over the one
  // 5-ms step that straddles it). With noise and a bias random walk, ~10 s between frames, the
  // error grows as the bias wanders (what the online estimate is for): the first frames' stay small.
  std::size_t kicks = 0;
  for (std::size_t i = 1; i < times.size(); ++i) {
    const GyroAttitude noisy_attitude(imuSpan(noisy, times[i - 1], times[i]), Eigen::Vector3d::Zero());
    const GyroAttitude attitude(imuSpan(exact, times[i - 1], times[i]), Eigen::Vector3d::Zero());
    const Eigen::Matrix3d truth = s.worldPoses()[i - 1].linear().transpose() * s.worldPoses()[i].linear();
    const double error = Eigen::AngleAxisd(attitude.between(times[i - 1], times[i]).transpose() * truth).angle();
    EXPECT_LT(error * 180.0 / M_PI, 0.02) << "frame " << i;
    const double noisy_error =
        Eigen::AngleAxisd(noisy_attitude.between(times[i - 1], times[i]).transpose() * truth).angle();
    if (i <= 3) EXPECT_LT(noisy_error * 180.0 / M_PI, 0.25) << "frame " << i;
    kicks += Eigen::AngleAxisd(truth).angle() > 10.0 * M_PI / 180.0;
  }
  EXPECT_GT(kicks, 0u);
  // The accelerometer: gravity, up in the sensor frame, plus the crawler's small accelerations.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& x : noisy) mean += x.accel / static_cast<double>(noisy.size());
  EXPECT_NEAR(mean.z(), 9.80665, 0.05);
  EXPECT_LT(mean.head<2>().norm(), 0.05);
}

TEST(SimImu, OwnRandomStreamAndWrittenOnlyWhenAsked) {
  const sim::Simulator with = shortCorridor(200.0), without = shortCorridor(0.0);
  for (std::size_t i : {0u, 7u, 39u}) {
    EXPECT_EQ(with.scan(i).points, without.scan(i).points);
    EXPECT_TRUE(with.odometry()[i].isApprox(without.odometry()[i], 0.0));
  }
  const auto a = sim::simulateImuStream(with.worldPoses(), frameTimes(with), with.config().imu, 5);
  const auto b = sim::simulateImuStream(with.worldPoses(), frameTimes(with), with.config().imu, 5);
  const auto c = sim::simulateImuStream(with.worldPoses(), frameTimes(with), with.config().imu, 6);
  EXPECT_EQ(a[100].gyro, b[100].gyro);
  EXPECT_NE(a[100].gyro, c[100].gyro);
  EXPECT_TRUE(sim::simulateImuStream(without.worldPoses(), frameTimes(without), without.config().imu, 5).empty());
  // simulation.yaml names the IMU stream's keys only when it is written.
  EXPECT_NE(with.config().toYamlString().find("gyro_noise_density"), std::string::npos);
  EXPECT_EQ(without.config().toYamlString().find("gyro_noise_density"), std::string::npos);
}

TEST(SimImu, SequenceFolderCarriesImuTxtToEveryScan) {
  const fs::path dir = test::scratchDir() / "imu_corridor";
  fs::remove_all(dir);
  const auto r = test::runCli("simulate --scenario corridor --frames 6 --imu-rate 200 --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(dir / "imu.txt"));
  auto source = openScanSource(dir);
  std::size_t with_imu = 0;
  std::optional<double> previous;
  while (auto scan = source->next()) {
    if (previous) {
      ASSERT_FALSE(scan->imu.empty()) << "scan " << scan->index;
      EXPECT_LE(scan->imu.front().time, *previous);
      EXPECT_GE(scan->imu.back().time, scan->stamp);
      ++with_imu;
    }
    previous = scan->stamp;
  }
  EXPECT_EQ(with_imu, 5u);
}

// ---------------------------------------------------------------------------------------------
// Using it: the real OS-1-128 capture (hand-held at ~2.5 m/s, turning a few °/s) tracked with the
// IMU's rotation (deskew + guess) and with constant-velocity deskewing, against ouster-sdk's own
// SLAM poses of the same scans. The IMU's must do at least as well.

namespace {

struct OusterTrack {
  std::vector<Eigen::Isometry3d> increments;
  std::vector<double> rmse;
};

OusterTrack trackOuster(bool use_imu) {
  auto source = openScanSource(os128Pcap());
  OdometryConfig config = OdometryConfig::defaults();
  config.registration.use_classes = false;
  Odometry odo(source->classTable(), config);
  StreamDeskewer deskewer(DeskewConfig{});
  ImuStreamMotion imu;
  OusterTrack out;
  while (auto scan = source->next()) {
    if (!use_imu) scan->imu.clear();
    const auto motion = imu.next(scan->imu, scan->stamp);
    if (use_imu && scan->index > 0) EXPECT_TRUE(motion.rotation) << "scan " << scan->index;
    deskewer.apply(scan->cloud, scan->stamp, std::nullopt, motion.attitudePtr());
    const OdometryFrame& f = odo.addFrame(scan->cloud, std::nullopt, scan->stamp, motion.rotation);
    deskewer.tracked(f.increment);
    imu.tracked(verifiedRotation(f));
    if (scan->index > 0) out.increments.push_back(f.increment), out.rmse.push_back(f.registration.inlier_rmse);
  }
  return out;
}

}  // namespace

TEST(ImuRun, OusterImuDeskewRegistersAtLeastAsWellAsConstantVelocity) {
  const Trajectory sdk = readKittiTrajectory(
      test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"));
  ASSERT_EQ(sdk.poses.size(), 3u);
  const OusterTrack imu = trackOuster(true), cv = trackOuster(false);
  ASSERT_EQ(imu.increments.size(), 2u);
  ASSERT_EQ(cv.increments.size(), 2u);
  Eigen::Vector3d sum_imu = Eigen::Vector3d::Zero(), sum_cv = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < 2; ++i) {
    const Eigen::Isometry3d truth = sdk.poses[i].inverse() * sdk.poses[i + 1];
    const double t_imu = test::transErr(imu.increments[i], truth), t_cv = test::transErr(cv.increments[i], truth);
    const double r_imu = test::rotErrDeg(imu.increments[i], truth), r_cv = test::rotErrDeg(cv.increments[i], truth);
    std::printf("OS-1-128 increment %zu vs ouster-sdk: IMU %.4f m %.3f deg rmse %.4f; constant velocity %.4f m %.3f deg rmse %.4f\n",
                i, t_imu, r_imu, imu.rmse[i], t_cv, r_cv, cv.rmse[i]);
    sum_imu += Eigen::Vector3d(t_imu, r_imu, imu.rmse[i]);
    sum_cv += Eigen::Vector3d(t_cv, r_cv, cv.rmse[i]);
  }
  // At least as well over the capture (both increments; ouster-sdk's poses are themselves an
  // estimate, good to a centimetre): translation and rotation error and the ICP's inlier RMSE.
  EXPECT_LE(sum_imu[0], sum_cv[0]);
  EXPECT_LE(sum_imu[1], sum_cv[1]);
  EXPECT_LE(sum_imu[2], sum_cv[2]);
}

// ---------------------------------------------------------------------------------------------
// Bags: sensor_msgs/Imu and the Ouster driver's imu_packets.

TEST(RosImu, CdrRoundTripAndBadMessagesNamed) {
  ImuMsg msg;
  msg.header.stamp = 1700000000.25;
  msg.header.frame_id = "imu_link";
  msg.angular_velocity = Eigen::Vector3d(0.01, -0.02, 0.5);
  msg.linear_acceleration = Eigen::Vector3d(0.1, 0.2, 9.81);
  for (bool big : {false, true}) {
    const auto bytes = encodeImu(msg, big);
    const ImuMsg back = decodeImu(bytes, Serialization::Cdr, "t");
    EXPECT_EQ(back.header.stamp, msg.header.stamp);
    EXPECT_EQ(back.angular_velocity, msg.angular_velocity);
    EXPECT_EQ(back.linear_acceleration, msg.linear_acceleration);
    auto cut = bytes;
    cut.resize(cut.size() - 8);
    EXPECT_NE(test::errorOf([&] { decodeImu(cut, Serialization::Cdr, "bag.mcap: /imu"); }).find("bag.mcap: /imu"),
              std::string::npos);
  }
  msg.angular_velocity.x() = std::nan("");
  EXPECT_NE(test::errorOf([&] { decodeImu(encodeImu(msg), Serialization::Cdr, "t"); }).find("non-finite"),
            std::string::npos);
}

TEST(OusterImu, RealRos1BagImuPacketsDecode) {
  // ouster_ros's bag: 10 IMU packets (ouster_ros/PacketMsg on /os_node0/imu_packets) over its
  // 0.097 s, beside the lidar packets of one scan, and the metadata on its own topic.
  const auto path = test::sharedData("sensors/ouster-os0-128-ros1/512x10_raw.bag");
  auto bag = openBag(path);
  std::string json;
  std::vector<std::vector<std::uint8_t>> imu_packets;
  BagMessage msg;
  while (bag->next(msg)) {
    if (msg.topic->name == "/os_node0/metadata") json = decodeString(msg.data, msg.topic->serialization, path.string());
    if (msg.topic->name == "/os_node0/imu_packets")
      imu_packets.push_back(decodeOusterPacket(msg.data, msg.topic->serialization, path.string()).data);
  }
  const OusterMetadata meta = parseOusterMetadata(json, path.string());
  ASSERT_EQ(imu_packets.size(), 10u);
  std::vector<double> times;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : imu_packets) {
    const auto d = decodeOusterImuPacket(p, meta);
    ASSERT_TRUE(d);
    times.push_back(static_cast<double>(d->gyro_time_ns) * 1e-9);
    mean += d->sample.accel / 10.0;
    EXPECT_LT(d->sample.gyro.norm(), 5.0 * M_PI / 180.0);  // on a bench
  }
  const double rate = 9.0 / (times.back() - times.front());
  std::printf("OS-0-128 bag IMU: %.1f Hz, mean specific force (%.3f %.3f %.3f) m/s^2\n", rate, mean.x(), mean.y(), mean.z());
  EXPECT_NEAR(rate, 100.0, 5.0);
  EXPECT_NEAR(mean.norm(), 9.81, 0.6);  // this unit reads 1.04 g at rest: an uncalibrated MEMS offset
  EXPECT_GT(mean.z(), 0.9 * mean.norm());  // upright: gravity along the sensor's z, up
  // The scan source reads the topic beside the lidar packets; its one scan's sweep (0.1 s) is not
  // covered by the 0.097 s of samples, so it keeps constant velocity (no samples attached).
  auto source = openScanSource(path);
  std::size_t scans = 0;
  while (auto scan = source->next()) {
    ++scans;
    if (!scan->imu.empty()) EXPECT_LE(scan->imu.front().time, scan->cloud.timestamps.front());
  }
  EXPECT_EQ(scans, 1u);
}

TEST(SimImu, McapCarriesTheImuAndReadsBackPerScan) {
  const fs::path bag = simulatedCorridorMcap("imu_corridor.mcap", 5);
  auto source = openScanSource(bag);
  std::size_t scans = 0, with_imu = 0;
  while (auto scan = source->next()) {
    ++scans;
    if (scan->index == 0 || scan->imu.empty()) continue;
    ++with_imu;
    EXPECT_NEAR(scan->imu.front().accel.z(), 9.81, 0.1);
  }
  EXPECT_EQ(scans, 5u);
  EXPECT_EQ(with_imu, 4u);
}

TEST(ImuStream, PoorStreamIsWarnedAndBridgedNeverFatal) {
  const fs::path dir = test::scratchDir() / "imu_poor";
  fs::remove_all(dir);
  ASSERT_EQ(test::runCli("simulate --scenario corridor --frames 5 --imu-rate 200 --out " + dir.string()).exit_code, 0);
  std::vector<ImuSample> s = readImuFile(dir / "imu.txt");
  ASSERT_GT(s.size(), 6000u);
  s.erase(s.begin() + 3000, s.begin() + 3400);  // a 2-s gap inside the third increment
  s.insert(s.begin() + 5000, s[4990]);           // out of order
  writeImuFile(dir / "imu.txt", s);
  const auto r = test::runCli("odometry " + dir.string() + " --out " + (dir / "odo").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 IMU samples out of time order dropped; 1 gaps in the IMU stream"), std::string::npos)
      << r.output;
  auto source = openScanSource(dir);
  std::vector<bool> covered;
  while (auto scan = source->next()) covered.push_back(!scan->imu.empty());
  EXPECT_EQ(covered, (std::vector<bool>{true, true, false, true, true}));  // the gap's increment: none
}

namespace {

/// Samples of a sensor rocking on a stand: attitude R(t) = Ry(pitch_rate·t)·Rx(tilt), so its gyro
/// reads the body rate Rx(tilt)ᵀ·(0, pitch_rate, 0) and its accelerometer R(t)ᵀ·(0, 0, g) (+ noise).
std::vector<ImuSample> rocking(double tilt, double pitch_rate, double seconds, double noise = 0.0) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, noise > 0.0 ? noise : 1.0);
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<ImuSample> out = evenSamples(0.0, 200.0, static_cast<std::size_t>(seconds * 200.0) + 1);
  for (ImuSample& s : out) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(pitch_rate * s.time, Eigen::Vector3d::UnitY()) * Rx;
    s.gyro = Rx.transpose() * Eigen::Vector3d(0.0, pitch_rate, 0.0);
    s.accel = R.transpose() * Eigen::Vector3d(0.0, 0.0, 9.80665);
    if (noise > 0.0) s.accel += Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  return out;
}

/// Angle (°) between the estimate's down and the true one of rocking() at time t.
double downError(const GravitySample& g, double tilt, double pitch_rate, double t) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(pitch_rate * t, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Vector3d down = R.transpose() * Eigen::Vector3d(0.0, 0.0, -1.0);
  return std::acos(std::clamp(g.down.dot(down), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace

// The pose graph's gravity prior from the accelerometer (no gravity.txt): the mean specific force
// within a second of the stamp, each sample turned into the stamp's frame by the gyro.
TEST(ImuGravity, TiltedAndRockingSensorGivesItsDownAtTheStamp) {
  const double tilt = 5.0 * M_PI / 180.0, pitch_rate = 3.0 * M_PI / 180.0;
  const auto samples = rocking(tilt, pitch_rate, 4.0, 0.02);  // a BMI088's white noise at 200 Hz
  const auto g = gravityFromAccelerometer(samples, 2.5, 0.0);
  ASSERT_TRUE(g);
  EXPECT_EQ(g->time, 2.5);
  EXPECT_LT(downError(*g, tilt, pitch_rate, 2.5), 0.02);
  // σ: the accelerometer's offset, 0.2 m/s² over g (1.17°), the noise averaged away.
  EXPECT_NEAR(g->sigma_deg, 1.168, 0.01);
  // Without the gyro's turn the samples of the two seconds (6° of pitch) average to the middle,
  // and a stamp that is not the middle reads that: at 3.5 s, the window 2.5–4 s is off by 0.75°.
  auto still = samples;
  for (ImuSample& s : still) s.gyro.setZero();
  const auto smeared = gravityFromAccelerometer(still, 3.5, 0.0);
  const auto turned = gravityFromAccelerometer(samples, 3.5, 0.0);
  ASSERT_TRUE(smeared && turned);
  EXPECT_GT(downError(*smeared, tilt, pitch_rate, 3.5), 0.5);
  EXPECT_LT(downError(*turned, tilt, pitch_rate, 3.5), 0.02);
}

TEST(ImuGravity, AcceleratingFallingOrTooFewSamplesGiveNoneOrAWiderSigma) {
  const auto samples = rocking(0.0, 0.0, 3.0);
  const auto calm = gravityFromAccelerometer(samples, 2.0, 0.0);
  const auto moving = gravityFromAccelerometer(samples, 2.0, 0.3);  // tracked: 0.3 m/s²
  ASSERT_TRUE(calm && moving);
  EXPECT_NEAR(moving->sigma_deg, std::atan(std::hypot(0.2, 0.3) / 9.80665) * 180.0 / M_PI, 1e-6);
  EXPECT_GT(moving->sigma_deg, 1.5 * calm->sigma_deg);
  EXPECT_FALSE(gravityFromAccelerometer(samples, 2.0, 1.0));  // σ 5.8° says nothing
  EXPECT_FALSE(gravityFromAccelerometer(samples, -0.96, 0.0));  // 9 samples within a second
  EXPECT_FALSE(gravityFromAccelerometer({}, 2.0, 0.0));
  auto falling = samples;
  for (ImuSample& s : falling) s.accel *= 0.8;  // 2 m/s² of free fall
  EXPECT_FALSE(gravityFromAccelerometer(falling, 2.0, 0.0));
}

// Real data: the OS-1-128 capture's own IMU (100 Hz, 0.3 s, the sensor on a vehicle at 2.5 m/s).
// Its accelerometer reads 10.5-10.6 m/s², 0.7-0.8 more than gravity, 4 m/s² of it along the
// sensor's x: a vehicle accelerating up a slope, or a tilted mounting — the road the scans see lies
// 22-24° from that direction, and nothing in the capture tells which. What the data can check:
// a prior owns up to the surplus (σ ≥ atan(surplus / g)), a scan whose σ would pass 5° gives
// none, and where two scans give one, ouster-sdk's rotation between them carries one onto the
// other within their σ.
TEST(ImuGravity, RealOusterCaptureOwnsItsUncertainty) {
  const Trajectory sdk = readKittiTrajectory(
      test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt"));
  auto source = openScanSource(os128Pcap());
  std::vector<std::pair<std::size_t, GravitySample>> found;
  std::size_t refused = 0;
  while (auto scan = source->next()) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const ImuSample& s : scan->imu) mean += s.accel / static_cast<double>(scan->imu.size());
    const double surplus = std::abs(mean.norm() - 9.80665);
    const auto g = gravityFromAccelerometer(scan->imu, scan->stamp, 0.0);
    std::printf("OS-1-128 scan %zu: %zu IMU samples, |mean f| %.3f m/s^2, %s", scan->index, scan->imu.size(),
                mean.norm(), g ? "" : "no prior\n");
    if (!g) {
      // Refused: too few samples (the first scan starts before the IMU's first packet) or σ > 5°.
      refused += scan->imu.size() >= 10 && std::atan(surplus / 9.80665) * 180.0 / M_PI > 4.5;
      continue;
    }
    std::printf("down %.3f %.3f %.3f sigma %.2f deg\n", g->down.x(), g->down.y(), g->down.z(), g->sigma_deg);
    EXPECT_GT(surplus, 0.5);
    EXPECT_GE(g->sigma_deg, std::atan(surplus / 9.80665) * 180.0 / M_PI);
    found.emplace_back(scan->index, *g);
  }
  ASSERT_GE(found.size(), 1u);
  EXPECT_GE(found.size() + refused, 2u);
  for (std::size_t k = 1; k < found.size(); ++k) {
    const auto& [i, gi] = found[k - 1];
    const auto& [j, gj] = found[k];
    const Eigen::Matrix3d R_i_j = (sdk.poses[i].inverse() * sdk.poses[j]).linear();
    const double angle = std::acos(std::clamp(gi.down.dot(R_i_j * gj.down), -1.0, 1.0)) * 180.0 / M_PI;
    EXPECT_LT(angle, std::hypot(gi.sigma_deg, gj.sigma_deg)) << i << " " << j;
  }
}

// --imu-rotation: R_lidar_imu for a sensor_msgs/Imu recorded in the IMU's own axes.
TEST(ImuRotation, ParsesEveryFormAndNamesBadInput) {
  const Eigen::Matrix3d Rz90 = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_TRUE(parseImuRotation("0,0,90", "--imu-rotation").isApprox(Rz90, 1e-12));
  EXPECT_TRUE(parseImuRotation("0.7071067811865476 0 0 0.7071067811865476", "x").isApprox(Rz90, 1e-9));
  EXPECT_TRUE(parseImuRotation("0,-1,0, 1,0,0, 0,0,1", "x").isApprox(Rz90, 1e-12));
  EXPECT_TRUE(parseImuRotation("0 -1 0 0.1  1 0 0 -0.2  0 0 1 0.05  0 0 0 1", "x").isApprox(Rz90, 1e-12));
  // roll, pitch, yaw: R = Rz(yaw)·Ry(pitch)·Rx(roll).
  const Eigen::Matrix3d rpy = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitY()) *
                              Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_TRUE(parseImuRotation("5.729577951308232,-11.459155902616464,17.188733853924695", "x").isApprox(rpy, 1e-12));
  const auto error = [](const std::string& text) { return test::errorOf([&] { parseImuRotation(text, "--imu-rotation"); }); };
  for (const auto& [text, what] : std::vector<std::pair<std::string, std::string>>{
           {"1,2", "got 2"},
           {"1,2,x", "'x' is not a number"},
           {"1,nan,3", "not finite"},
           {"1,0,0,0.5", "not a unit quaternion"},
           {"1,0,0, 0,2,0, 0,0,1", "not a rotation"},
           {"-1,0,0, 0,1,0, 0,0,1", "not a rotation"},
           {"1 0 0 0  0 1 0 0  0 0 1 0  0 0 1 1", "last row"}}) {
    const std::string e = error(text);
    EXPECT_NE(e.find("--imu-rotation"), std::string::npos) << text << ": " << e;
    EXPECT_NE(e.find(what), std::string::npos) << text << ": " << e;
  }
}

TEST(ImuRotation, BagSamplesAreTurnedIntoTheLidarsAxesAndABadFlagIsOneLine) {
  const fs::path bag = simulatedCorridorMcap("imu_rotation.mcap", 3);
  ScanSourceOptions turned;
  turned.imu_rotation = parseImuRotation("10,-20,90", "test");
  auto plain = openScanSource(bag), rotated = openScanSource(bag, turned);
  std::size_t compared = 0;
  while (auto a = plain->next()) {
    const auto b = rotated->next();
    ASSERT_TRUE(b);
    ASSERT_EQ(a->imu.size(), b->imu.size());
    for (std::size_t k = 0; k < a->imu.size(); ++k, ++compared) {
      EXPECT_TRUE(b->imu[k].gyro.isApprox(*turned.imu_rotation * a->imu[k].gyro, 1e-12));
      EXPECT_TRUE(b->imu[k].accel.isApprox(*turned.imu_rotation * a->imu[k].accel, 1e-12));
    }
  }
  EXPECT_GT(compared, 100u);
  const auto bad = test::runCli("info " + bag.string() + " --imu-rotation 1,2");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("--imu-rotation: expected"), std::string::npos) << bad.output;
  fs::remove(bag);
}
