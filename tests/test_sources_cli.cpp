// The CLI on real recordings: `hazmap run` completes on every bag and capture of
// ../shared/data/sensors, `hazmap odometry` on the OS-1-128 capture agrees with ouster-sdk's own
// poses, `info`/`convert` of recordings, topic errors, and simulate --format mcap → run.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

std::string quoted(const fs::path& p) { return "'" + p.string() + "'"; }

nlohmann::json readJson(const fs::path& p) { return nlohmann::json::parse(readTextFile(p)); }

struct Recording {
  const char* name;
  const char* path;   ///< under sensors/
  const char* flags;  ///< e.g. the topic of a bag with two LiDAR topics
  std::size_t scans;
  int fallbacks = 0;  ///< frames ICP cannot register (see the recording's comment)
};

void PrintTo(const Recording& r, std::ostream* os) { *os << r.name; }

class RunOnRecording : public ::testing::TestWithParam<Recording> {};

const Recording kRecordings[] = {
    {"vlp16_rosbag2", "velodyne-vlp16", "", 4},
    {"vlp32_rosbag2", "velodyne-vlp32", "", 5},
    {"vls128_rosbag2", "velodyne-vls128", "", 4},
    {"mcap_zstd", "mcap/velodyne-zstd-chunked.mcap", "--lidar-topic /velodyne_points", 3},
    {"mcap_lz4", "mcap/ouster-lz4-chunked.mcap", "--lidar-topic /velodyne_points", 3},
    {"mcap_unindexed", "mcap/velodyne-unchunked-no-index.mcap", "--lidar-topic /velodyne_points", 3},
    {"os0_128_ros1", "ouster-os0-128-ros1/512x10_raw.bag", "", 1},
    {"os1_128_pcap", "ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap", "", 3},
    {"os1_64_pcap", "ouster-os1-64/ouster_example.pcap", "", 1},
    // One rotation cut at azimuth 0 like the drivers do: two scans of disjoint azimuths, so the
    // second cannot be registered to the first (fitness 0.03) and the run keeps its guess.
    {"vlp16_pcap", "velodyne-vlp16-pcap/velodyne_vlp16.pcap", "", 2, 1},
};

}  // namespace

TEST_P(RunOnRecording, CompletesWithAPosePerScanAndAMap) {
  const Recording& r = GetParam();
  const fs::path out = test::scratchDir() / "run";
  const auto result = test::runCli("run " + quoted(test::sharedData(std::string("sensors/") + r.path)) + " " +
                                   r.flags + " --out " + quoted(out));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  const auto j = readJson(out / "run.json");
  EXPECT_EQ(j["frames"], r.scans) << result.output;
  EXPECT_EQ(readKittiTrajectory(out / "trajectory.kitti").size(), r.scans);
  EXPECT_GT(j["map"]["cells"].get<std::size_t>(), 1000u);
  EXPECT_NE(j["sequence"].get<std::string>().find(r.path), std::string::npos);
  // Every frame registered (no fallback to a guess) on these short, sharp recordings.
  EXPECT_EQ(j["tracking"]["odometry_fallbacks"], r.fallbacks) << j["tracking"].dump();
}

INSTANTIATE_TEST_SUITE_P(Sensors, RunOnRecording, ::testing::ValuesIn(kRecordings),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(OdometryOnRecording, Os1128AgreesWithOusterSdkPosesWithin5cmAndHalfADegree) {
  const fs::path dir = test::sharedData("sensors/ouster-os1-128");
  const fs::path out = test::scratchDir();
  for (const char* deskew : {"", "--no-deskew"}) {
    const auto r = test::runCli("odometry " + quoted(dir / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap") + " --out " +
                                quoted(out / (deskew[0] ? "raw" : "deskewed")) + " " + deskew);
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const Trajectory sdk = readKittiTrajectory(dir / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt");
  const Trajectory ours = readKittiTrajectory(out / "deskewed/poses.txt");
  const Trajectory raw = readKittiTrajectory(out / "raw/poses.txt");
  ASSERT_EQ(sdk.size(), 3u);
  ASSERT_EQ(ours.size(), 3u);
  for (std::size_t i = 1; i < 3; ++i) {
    const Eigen::Isometry3d sdk_motion = sdk.poses[i - 1].inverse() * sdk.poses[i];
    const Eigen::Isometry3d our_motion = ours.poses[i - 1].inverse() * ours.poses[i];
    const Eigen::Isometry3d error = sdk_motion.inverse() * our_motion;
    EXPECT_LT(translationNorm(error), 0.05) << "scan " << i;
    EXPECT_LT(rotationAngle(error), 0.5 * M_PI / 180) << "scan " << i;
    EXPECT_GT(translationNorm(sdk_motion), 0.2);  // the sensor moves ~2.5 m/s: a real test
  }
  // Deskewing was applied from the second scan on: the capture's IMU packets cover it (the first
  // starts before the first IMU sample); without an IMU only from the third (the first motion
  // estimate is the first two), tests/test_imu.cpp compares both.
  EXPECT_GT((ours.poses[1].translation() - raw.poses[1].translation()).norm(), 1e-3);
  EXPECT_GT((ours.poses[2].translation() - raw.poses[2].translation()).norm(), 1e-3);
}

TEST(InfoOnRecording, ListsTopicsDurationAndScansAsJson) {
  auto r = test::runCli("info --json " + quoted(test::sharedData("sensors/velodyne-vlp16")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["kind"], "bag");
  ASSERT_EQ(j["topics"].size(), 1u);
  EXPECT_EQ(j["topics"][0]["name"], "/velodyne_packets");
  EXPECT_EQ(j["topics"][0]["type"], "velodyne_msgs/msg/VelodyneScan");
  EXPECT_EQ(j["topics"][0]["count"], 4);
  EXPECT_NEAR(j["duration_s"].get<double>(), 0.30, 0.01);
  ASSERT_EQ(j["frames"], 4);
  for (const auto& f : j["frame_list"]) EXPECT_GT(f["points"].get<std::size_t>(), 14000u);  // dual return VLP-16
  EXPECT_NE(j["lidar"].get<std::string>().find("VLP-16"), std::string::npos) << j["lidar"];

  // Two PointCloud2 topics: the topics are still listed, the LiDAR part says what to choose.
  const fs::path mcap = test::sharedData("sensors/mcap/velodyne-zstd-chunked.mcap");
  r = test::runCli("info --json " + quoted(mcap));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["topics"].size(), 4u);
  EXPECT_EQ(j["frames"], 0);
  EXPECT_NE(j["lidar_error"].get<std::string>().find("--lidar-topic"), std::string::npos);
  r = test::runCli("info --json --lidar-topic /velodyne_points " + quoted(mcap));
  j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["frames"], 3);
  for (const auto& f : j["frame_list"]) {
    EXPECT_EQ(f["points"], 14831);
    EXPECT_TRUE(f["odometry"].get<bool>());
  }
  // A capture: its UDP streams.
  r = test::runCli("info --json " + quoted(test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap")));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  j = nlohmann::json::parse(r.output);
  EXPECT_EQ(j["kind"], "capture");
  EXPECT_EQ(j["frames"], 3);
  for (const auto& f : j["frame_list"]) EXPECT_GT(f["points"].get<std::size_t>(), 100000u);  // 128 × 1024 minus no-returns
}

TEST(ConvertRecording, WritesASequenceFolderThatRunsLikeTheBag) {
  const fs::path mcap = test::sharedData("sensors/mcap/velodyne-zstd-chunked.mcap");
  const fs::path dir = test::scratchDir();
  auto r = test::runCli("convert " + quoted(mcap) + " " + quoted(dir / "seq") + " --lidar-topic /velodyne_points");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"velodyne/000000.pcd", "velodyne/000002.pcd", "times.txt", "odometry.txt", "hazmap.yaml"})
    EXPECT_TRUE(fs::exists(dir / "seq" / f)) << f;
  EXPECT_FALSE(fs::exists(dir / "seq/velodyne/000003.pcd"));
  // The odometry (x = 0, 0.5, 1 m, yaw 0, 0.1, 0.2 rad at the clouds' header stamps) interpolated
  // at each scan's middle; the last scan is after the last odometry message (clamped).
  const Trajectory odom = readKittiTrajectory(dir / "seq/odometry.txt");
  std::vector<double> times;
  std::ifstream in(dir / "seq/times.txt");
  for (double t; in >> t;) times.push_back(t);
  ASSERT_EQ(times.size(), 3u);
  ASSERT_EQ(odom.size(), 3u);
  for (std::size_t i = 0; i < 2; ++i) {
    const double s = (times[i] - 0.1 * static_cast<double>(i)) / 0.1;
    EXPECT_GT(s, 0.0);
    EXPECT_NEAR(odom.poses[i].translation().x(), 0.5 * (static_cast<double>(i) + s), 1e-9);
    EXPECT_NEAR(yawOf(odom.poses[i]), 0.1 * (static_cast<double>(i) + s), 1e-9);
  }
  EXPECT_NEAR(odom.poses[2].translation().x(), 1.0, 1e-12);

  // The folder runs as the bag does (the PCDs keep the per-point times, so deskewing is the same).
  r = test::runCli("run " + quoted(dir / "seq") + " --out " + quoted(dir / "run-folder"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::runCli("run " + quoted(mcap) + " --lidar-topic /velodyne_points --out " + quoted(dir / "run-bag"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Trajectory a = readKittiTrajectory(dir / "run-folder/trajectory.kitti");
  const Trajectory b = readKittiTrajectory(dir / "run-bag/trajectory.kitti");
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_LT((a.poses[i].translation() - b.poses[i].translation()).norm(), 1e-6) << i;
}

TEST(ConvertRecording, AnErrorLeavesNothingBehind) {
  const fs::path dir = test::scratchDir();
  const auto r = test::runCli("convert " + quoted(test::sharedData("sensors/mcap/velodyne-zstd-chunked.mcap")) + " " +
                              quoted(dir / "seq"));  // two PointCloud2 topics, none chosen
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--lidar-topic"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::is_empty(dir)) << "partial output left";
}

TEST(RunOnRecording, WrongTopicIsAOneLineErrorListingTheCandidates) {
  const fs::path dir = test::scratchDir();
  const fs::path mcap = test::sharedData("sensors/mcap/velodyne-zstd-chunked.mcap");
  auto r = test::runCli("run " + quoted(mcap) + " --lidar-topic /nope --quiet --out " + quoted(dir / "out"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("'/nope' not found"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("/velodyne_points (sensor_msgs/msg/PointCloud2)"), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
  r = test::runCli("run " + quoted(mcap) + " --lidar-topic /velodyne_points --odom-topic /thermal/image_raw --quiet "
                   "--out " + quoted(dir / "out"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("is sensor_msgs/msg/Image, not a odometry topic; odometry topics: /odom"),
            std::string::npos)
      << r.output;
  // Topics not read are named, one line each.
  r = test::runCli("odometry " + quoted(mcap) + " --lidar-topic /velodyne_points --out " + quoted(dir / "odo"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("/thermal/image_raw (sensor_msgs/msg/Image): not read"), std::string::npos) << r.output;
  // A Velodyne calibration that is not there.
  r = test::runCli("run " + quoted(test::sharedData("sensors/velodyne-vlp16")) + " --quiet --velodyne-calibration " +
                   quoted(dir / "missing.yaml") + " --out " + quoted(dir / "out"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find((dir / "missing.yaml").string()), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "out"));
  // An Ouster capture without its metadata.
  fs::copy_file(test::sharedData("sensors/ouster-os1-64/ouster_example.pcap"), dir / "ouster.pcap");
  r = test::runCli("run " + quoted(dir / "ouster.pcap") + " --quiet --out " + quoted(dir / "out"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--sensor-metadata"), std::string::npos) << r.output;
  r = test::runCli("run " + quoted(dir / "ouster.pcap") + " --quiet --out " + quoted(dir / "out") +
                   " --sensor-metadata " + quoted(test::sharedData("sensors/ouster-os1-64/ouster_example.json")));
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST(SimulateMcap, BagToMapGivesTheFolderRunsMapError) {
  const fs::path dir = test::scratchDir();
  const std::string sim = "simulate --scenario corridor --seed 5 --frames 12 ";
  auto r = test::runCli(sim + "--out " + quoted(dir / "seq"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::runCli(sim + "--format mcap --out " + quoted(dir / "seq.mcap"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // Nothing but the bag is left next to it.
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++entries;
  EXPECT_EQ(entries, 2u);
  r = test::runCli("info --json " + quoted(dir / "seq.mcap"));
  const auto info = nlohmann::json::parse(r.output);
  EXPECT_EQ(info["frames"], 12);
  for (const char* method : {"property-icp+pgo", "icp"}) {
    // The bag has no IMU topic (gravity.txt is not exported), so the folder run leaves its
    // gravity priors out to see the same data.
    r = test::runCli("run " + quoted(dir / "seq") + " --quiet --method " + method +
                     " --set graph.gravity_prior=false --out " + quoted(dir / "folder"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = test::runCli("run " + quoted(dir / "seq.mcap") + " --quiet --method " + method + " --out " + quoted(dir / "bag"));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const auto folder = readJson(dir / "folder/run.json"), bag = readJson(dir / "bag/run.json");
    // Same scans, classes, odometry and truth; only the odometry's rotation went through a
    // quaternion (differences of 1e-16), so the map error agrees to far below a micrometre.
    EXPECT_NEAR(folder["map_error"]["point"]["mean"].get<double>(), bag["map_error"]["point"]["mean"].get<double>(),
                1e-9)
        << method;
    EXPECT_EQ(folder["loop_closure"]["accepted"], bag["loop_closure"]["accepted"]);
    const Trajectory a = readKittiTrajectory(dir / "folder/trajectory.kitti");
    const Trajectory b = readKittiTrajectory(dir / "bag/trajectory.kitti");
    ASSERT_EQ(a.size(), 12u);
    ASSERT_EQ(b.size(), 12u);
    for (std::size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(a.poses[i].isApprox(b.poses[i], 1e-9)) << i;
  }
}

// A recording's IMU survives the conversion (`hazmap label BAG` and `run BAG --camera` convert
// first): the OS-1-128 capture's folder gives every scan the same samples as the capture does.
TEST(ConvertRecording, TheImuStreamComesAlongAndEachScanGetsTheSameSamples) {
  const fs::path pcap = test::sharedData("sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  const fs::path dir = test::scratchDir();
  const auto r = test::runCli("convert " + quoted(pcap) + " " + quoted(dir / "seq"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("imu.txt ("), std::string::npos) << r.output;
  ASSERT_TRUE(fs::exists(dir / "seq/imu.txt"));
  auto capture = openScanSource(pcap), folder = openScanSource(dir / "seq");
  std::size_t samples = 0;
  while (auto a = capture->next()) {
    const auto b = folder->next();
    ASSERT_TRUE(b);
    ASSERT_EQ(a->imu.size(), b->imu.size()) << "scan " << a->index;
    for (std::size_t k = 0; k < a->imu.size(); ++k, ++samples) {
      EXPECT_EQ(a->imu[k].time, b->imu[k].time);
      EXPECT_EQ(a->imu[k].gyro, b->imu[k].gyro);
      EXPECT_EQ(a->imu[k].accel, b->imu[k].accel);
    }
  }
  EXPECT_FALSE(folder->next());
  EXPECT_GE(samples, 30u);
  fs::remove_all(dir);
}
