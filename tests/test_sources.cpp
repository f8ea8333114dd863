// Scan streams: sequence folders as ScanSources, runSlam over a stream, pose interpolation,
// deskewing, topic selection (and, with the bag and capture readers, the real recordings).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/preprocess/deskew.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sources/pose_buffer.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "sources/topic_selection.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

// A short simulated corridor (made once per test process).
const fs::path& corridorSequence() {
  static const fs::path dir = test::writeSimulatedSequence("sources-corridor", "corridor", 3, 12);
  return dir;
}

// The same scans as a stream that does not know its length and cannot re-read (like a bag).
class StreamOnly final : public ScanSource {
 public:
  explicit StreamOnly(std::unique_ptr<ScanSource> inner) : inner_(std::move(inner)) {}
  std::optional<Scan> next() override { return inner_->next(); }
  std::optional<std::size_t> size() const override { return std::nullopt; }
  const ClassTable& classTable() const override { return inner_->classTable(); }
  std::string describe() const override { return "stream of " + inner_->describe(); }

 private:
  std::unique_ptr<ScanSource> inner_;
};

void expectSamePoses(const Trajectory& a, const Trajectory& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(a.poses[i].isApprox(b.poses[i], 0.0)) << i;
}

}  // namespace

TEST(SequenceSource, YieldsScansWithOdometryTruthAndTimes) {
  const Sequence seq = Sequence::open(corridorSequence());
  const auto source = openScanSource(corridorSequence());
  ASSERT_EQ(source->size(), seq.size());
  EXPECT_TRUE(source->canReread());
  std::size_t n = 0;
  double last_stamp = -1;
  while (auto scan = source->next()) {
    EXPECT_EQ(scan->index, n);
    EXPECT_EQ(scan->cloud.points, seq.frame(n).points);
    ASSERT_TRUE(scan->odometry && scan->ground_truth);
    EXPECT_TRUE(scan->odometry->isApprox(seq.odometry()->poses[n], 0.0));
    EXPECT_TRUE(scan->ground_truth->isApprox(seq.groundTruth()->poses[n], 0.0));
    EXPECT_GT(scan->stamp, last_stamp);  // times.txt
    last_stamp = scan->stamp;
    ++n;
  }
  EXPECT_EQ(n, seq.size());
  EXPECT_FALSE(source->next().has_value());
  EXPECT_EQ(source->reread(3).points, seq.frame(3).points);
}

TEST(SequenceSource, MissingOrWrongPathIsAOneLineError) {
  try {
    openScanSource(test::scratchDir() / "nothing-here");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
  }
  const fs::path dir = test::scratchDir();
  std::ofstream(dir / "notes.txt") << "hello\n";
  try {
    openScanSource(dir / "notes.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("notes.txt"), std::string::npos) << e.what();
  }
}

TEST(SlamStream, AStreamOfUnknownLengthGivesTheSequenceRunBitForBit) {
  SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  const SlamResult folder = runSlam(Sequence::open(corridorSequence()), config);
  StreamOnly stream(openScanSource(corridorSequence()));
  std::vector<std::size_t> totals;
  const SlamResult streamed =
      runSlam(stream, config, [&](std::size_t done, std::size_t total) { totals.push_back(total + 1000 * done); });
  expectSamePoses(folder.estimate, streamed.estimate);
  expectSamePoses(folder.tracked, streamed.tracked);
  expectSamePoses(folder.odometry_only, streamed.odometry_only);
  EXPECT_EQ(folder.loops.size(), streamed.loops.size());
  ASSERT_EQ(totals.size(), folder.frames.size());
  for (std::size_t i = 0; i < totals.size(); ++i) EXPECT_EQ(totals[i], 1000 * (i + 1)) << "total must be 0";
  EXPECT_EQ(streamed.source, "stream of " + corridorSequence().string());
  // Stamps come from times.txt.
  EXPECT_GT(folder.estimate.stamps.back(), 0.0);
}

TEST(SlamStream, KeyframesOfAStreamReloadFromDiskBitForBit) {
  // One resident keyframe: every loop candidate reloads its match (the folder from the
  // sequence, the stream from the keyframe copies on disk). Long enough for loops.
  SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  config.loop_closure.resident_keyframes = 1;
  const fs::path dir = test::scratchDir() / "seq";
  sim::SimulatorConfig sim;
  sim.scenario = "naraha";
  sim.seed = 2;
  sim.max_frames = 40;
  sim::writeSimulation(sim, dir, /*overwrite=*/true);
  const SlamResult folder = runSlam(Sequence::open(dir), config);
  StreamOnly stream(openScanSource(dir));
  const SlamResult streamed = runSlam(stream, config);
  EXPECT_GT(folder.loop_candidates, 0u);
  EXPECT_EQ(folder.loop_candidates, streamed.loop_candidates);
  EXPECT_EQ(folder.loops_verified, streamed.loops_verified);
  expectSamePoses(folder.estimate, streamed.estimate);
}

TEST(SlamStream, OdometryMethodWithoutOdometryNamesTheSource) {
  const fs::path dir = test::scratchDir();
  fs::create_directories(dir / "seq/velodyne");
  fs::copy_file(corridorSequence() / "velodyne/000000.bin", dir / "seq/velodyne/000000.bin");
  const auto source = openScanSource(dir / "seq");
  try {
    runSlam(*source, SlamConfig::forMethod(SlamMethod::Odometry));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find((dir / "seq").string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("wheel odometry"), std::string::npos) << e.what();
  }
}

TEST(PoseBuffer, InterpolatesSlerpAndLerpAndClampsAtTheEnds) {
  PoseBuffer b;
  EXPECT_FALSE(b.at(0.0).has_value());
  const Eigen::Isometry3d A = fromXyzRpy(1, 2, 3, 0.1, 0.0, 0.2), B = fromXyzRpy(2, 2, 5, 0.1, 0.0, 0.6);
  ASSERT_TRUE(b.push(10.0, A));
  ASSERT_TRUE(b.push(10.5, B));
  EXPECT_FALSE(b.push(10.2, A));  // older than the last one
  EXPECT_TRUE(b.covers(10.5));
  EXPECT_FALSE(b.covers(10.6));
  bool clamped = false;
  const Eigen::Isometry3d mid = *b.at(10.25, &clamped);
  EXPECT_FALSE(clamped);
  EXPECT_NEAR((mid.translation() - Eigen::Vector3d(1.5, 2, 4)).norm(), 0.0, 1e-12);
  // Halfway in rotation: the same angle from A as to B.
  EXPECT_NEAR(rotationAngle(A.inverse() * mid), rotationAngle(mid.inverse() * B), 1e-9);
  EXPECT_NEAR(rotationAngle(A.inverse() * mid), 0.2, 1e-9);
  EXPECT_TRUE(b.at(9.0, &clamped)->isApprox(A));
  EXPECT_TRUE(clamped);
  EXPECT_TRUE(b.at(11.0, &clamped)->isApprox(B));
  EXPECT_TRUE(clamped);
  b.dropBefore(10.6);
  EXPECT_EQ(b.size(), 1u);
}

namespace {

// A room of points seen by a sensor that moves during the sweep: point i is measured at time
// t_i in the sensor frame of that instant. The truth is the room in the frame at `stamp`.
struct MovingScan {
  LabeledCloud measured, truth;
  Vector6d velocity;
  double stamp = 100.0;
};

MovingScan movingScan() {
  MovingScan s;
  s.velocity << 1.5, 0.3, 0.0, 0.0, 0.0, 0.8;  // 1.5 m/s forward, turning at 0.8 rad/s
  s.measured.enableTimestamps();
  const int n = 3600;
  for (int i = 0; i < n; ++i) {
    const double azimuth = 2 * M_PI * i / n;
    const double t = s.stamp + 0.1 * i / n;  // one 10 Hz sweep
    // A wall 8 m around the start pose, points at 1 m height.
    const Eigen::Vector3d p_ref(8 * std::cos(azimuth), 8 * std::sin(azimuth), 1.0);
    const Eigen::Isometry3d T_ref_t = se3Exp(s.velocity * (t - s.stamp));
    s.truth.push_back(p_ref.cast<float>());
    s.measured.push_back((T_ref_t.inverse() * p_ref).cast<float>(), 0, 0.0f, t);
  }
  return s;
}

double maxError(const LabeledCloud& a, const LabeledCloud& b) {
  double e = 0;
  for (std::size_t i = 0; i < a.size(); ++i) e = std::max(e, double((a.points[i] - b.points[i]).norm()));
  return e;
}

}  // namespace

TEST(Deskew, RecoversTheSceneOfASyntheticMovingSweep) {
  MovingScan s = movingScan();
  EXPECT_GT(maxError(s.measured, s.truth), 0.5);  // the skew the test removes
  EXPECT_EQ(deskewScan(s.measured, s.velocity, s.stamp), s.measured.size());
  EXPECT_LT(maxError(s.measured, s.truth), 1e-5);
  // A cloud without per-point times is left alone.
  LabeledCloud no_times = s.truth;
  EXPECT_EQ(deskewScan(no_times, s.velocity, s.stamp), 0u);
  EXPECT_EQ(no_times.points, s.truth.points);
}

TEST(Deskew, VelocityOfAnIncrementIsTheConstantMotion) {
  Vector6d v;
  v << 0.5, -0.2, 0.1, 0.02, -0.01, 0.3;
  const Eigen::Isometry3d T = se3Exp(v * 0.1);
  EXPECT_TRUE(velocityOfIncrement(T, 0.1).isApprox(v, 1e-9));
  EXPECT_THROW(velocityOfIncrement(T, 0.0), Error);
}

TEST(Deskew, StreamUsesTheLastTrackedIncrementOrTheWheelsAndSkipsGaps) {
  const MovingScan s = movingScan();
  const Eigen::Isometry3d per_scan = se3Exp(s.velocity * 0.1);
  // Constant velocity: scans 0 and 1 have no motion known yet, scan 2 uses 0→1's increment.
  StreamDeskewer cv(DeskewConfig{});
  for (int k = 0; k < 3; ++k) {
    MovingScan scan = movingScan();
    for (double& t : scan.measured.timestamps) t += 0.1 * k;
    const auto velocity = cv.apply(scan.measured, scan.stamp + 0.1 * k, std::nullopt);
    cv.tracked(k == 0 ? Eigen::Isometry3d::Identity() : per_scan);
    if (k < 2) {
      EXPECT_FALSE(velocity.has_value()) << k;
      continue;
    }
    ASSERT_TRUE(velocity.has_value());
    EXPECT_TRUE(velocity->isApprox(s.velocity, 1e-9));
    EXPECT_LT(maxError(scan.measured, scan.truth), 1e-5);
  }
  // Wheel odometry: the increment into the scan, from the second scan on.
  DeskewConfig wheel_config;
  wheel_config.motion = DeskewMotion::WheelOdometry;
  StreamDeskewer wheel(wheel_config);
  MovingScan first = movingScan(), second = movingScan();
  EXPECT_FALSE(wheel.apply(first.measured, first.stamp, std::nullopt));
  for (double& t : second.measured.timestamps) t += 0.1;
  ASSERT_TRUE(wheel.apply(second.measured, second.stamp + 0.1, per_scan));
  EXPECT_LT(maxError(second.measured, second.truth), 1e-5);
  // A gap longer than max_increment_gap: left as it is.
  MovingScan late = movingScan();
  for (double& t : late.measured.timestamps) t += 5.0;
  EXPECT_FALSE(wheel.apply(late.measured, late.stamp + 5.0, per_scan));
  // Off.
  DeskewConfig off;
  off.enabled = false;
  StreamDeskewer none(off);
  MovingScan a = movingScan(), b = movingScan();
  none.apply(a.measured, a.stamp, std::nullopt);
  EXPECT_FALSE(none.apply(b.measured, b.stamp + 0.1, per_scan));
}

TEST(TopicSelection, PicksTheOnlyLidarAndOdometryAndListsCandidatesOtherwise) {
  std::vector<TopicInfo> topics = {{"/velodyne_points", "sensor_msgs/msg/PointCloud2"},
                                   {"/odom", "nav_msgs/msg/Odometry"},
                                   {"/thermal/image_raw", "sensor_msgs/msg/Image"},
                                   {"/ground_truth", "geometry_msgs/msg/PoseStamped"}};
  auto s = sources::selectTopics(topics, {}, "bag");
  EXPECT_EQ(s.lidar->name, "/velodyne_points");
  EXPECT_EQ(s.kind, sources::LidarKind::PointCloud2);
  ASSERT_TRUE(s.odometry && s.ground_truth);
  EXPECT_EQ(s.odometry->name, "/odom");
  ASSERT_EQ(s.skipped.size(), 1u);
  EXPECT_NE(s.skipped[0].find("/thermal/image_raw (sensor_msgs/msg/Image)"), std::string::npos);

  topics.push_back({"/points_raw", "sensor_msgs/msg/PointCloud2"});
  const auto message = [&](const ScanSourceOptions& o) {
    try {
      sources::selectTopics(topics, o, "bag");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string ambiguous = message({});
  EXPECT_NE(ambiguous.find("--lidar-topic"), std::string::npos) << ambiguous;
  EXPECT_NE(ambiguous.find("/points_raw (sensor_msgs/msg/PointCloud2)"), std::string::npos) << ambiguous;
  EXPECT_EQ(ambiguous.find('\n'), std::string::npos);
  ScanSourceOptions o;
  o.lidar_topic = "/points_raw";
  EXPECT_EQ(sources::selectTopics(topics, o, "bag").lidar->name, "/points_raw");
  o.lidar_topic = "/nope";
  EXPECT_NE(message(o).find("'/nope' not found"), std::string::npos) << message(o);
  o.lidar_topic = "/odom";
  EXPECT_NE(message(o).find("is nav_msgs/msg/Odometry, not a LiDAR topic"), std::string::npos) << message(o);
  o.lidar_topic = "/points_raw";
  o.odom_topic = "/velodyne_points";
  EXPECT_NE(message(o).find("--odom-topic"), std::string::npos) << message(o);

  // Ouster: lidar packets, not the IMU packets of the same type; the metadata topic comes along.
  const std::vector<TopicInfo> ouster = {{"/os_node0/imu_packets", "ouster_ros/msg/PacketMsg"},
                                         {"/os_node0/lidar_packets", "ouster_ros/msg/PacketMsg"},
                                         {"/os_node0/metadata", "std_msgs/msg/String"}};
  s = sources::selectTopics(ouster, {}, "bag");
  EXPECT_EQ(s.lidar->name, "/os_node0/lidar_packets");
  EXPECT_EQ(s.kind, sources::LidarKind::OusterPackets);
  ASSERT_TRUE(s.ouster_metadata);
  EXPECT_EQ(s.ouster_metadata->name, "/os_node0/metadata");
  EXPECT_FALSE(s.odometry);
  try {
    sources::selectTopics({{"/imu", "sensor_msgs/msg/Imu"}}, {}, "bag");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no LiDAR topic"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("/imu (sensor_msgs/msg/Imu)"), std::string::npos) << e.what();
  }
}
