#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <fstream>
#include <sstream>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/demo/demo.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

// A short simulated corridor sequence, made once per test process (CTest runs the tests of this
// file as parallel processes, so each makes its own).
const fs::path& corridorSequence() {
  static const fs::path dir = test::writeSimulatedSequence("pipeline-corridor", "corridor", 7, 25);
  return dir;
}

nlohmann::json readJson(const fs::path& p) { return nlohmann::json::parse(readTextFile(p)); }

}  // namespace

TEST(SlamMethod, NamesRoundTripAndUnknownIsAnError) {
  for (SlamMethod m : kAllSlamMethods) EXPECT_EQ(parseSlamMethod(toString(m)), m);
  try {
    parseSlamMethod("magic");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown method 'magic'"), std::string::npos);
  }
  EXPECT_TRUE(usesClasses(SlamMethod::PropertyIcp));
  EXPECT_FALSE(usesClasses(SlamMethod::IcpPgo));
  EXPECT_TRUE(usesPoseGraph(SlamMethod::IcpPgo));
  EXPECT_FALSE(usesIcp(SlamMethod::Odometry));
}

TEST(SlamRun, OdometryMethodReproducesOdometryTxt) {
  const Sequence seq = Sequence::open(corridorSequence());
  const SlamResult r = runSlam(seq, SlamConfig::forMethod(SlamMethod::Odometry));
  ASSERT_EQ(r.estimate.size(), seq.size());
  const auto& odo = *seq.odometry();
  for (std::size_t i = 0; i < seq.size(); ++i)
    EXPECT_LT((r.estimate.poses[i].translation() - odo.poses[i].translation()).norm(), 1e-6);
  EXPECT_EQ(r.graph.numNodes(), static_cast<int>(seq.size()));
  EXPECT_EQ(r.graph.numLoopEdges(), 0);
}

TEST(SlamRun, PropertyIcpTracksBetterThanOdometryInTheCorridor) {
  const Sequence seq = Sequence::open(corridorSequence());
  const auto& truth = *seq.groundTruth();
  const auto finalError = [&](const Trajectory& t) {
    return (t.poses.back().translation() - truth.poses.back().translation()).norm();
  };
  const SlamResult odo = runSlam(seq, SlamConfig::forMethod(SlamMethod::Odometry));
  const SlamResult prop = runSlam(seq, SlamConfig::forMethod(SlamMethod::PropertyIcp));
  ASSERT_EQ(prop.frames.size(), seq.size());
  EXPECT_LT(finalError(prop.estimate), finalError(odo.estimate));
  EXPECT_GT(prop.framesPerSecond(), 0.0);
  // Every ICP edge carries an information matrix from the ICP covariance: symmetric, PD.
  for (const auto& e : prop.graph.edges) {
    EXPECT_TRUE(e.information.isApprox(e.information.transpose(), 1e-9));
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix6d>(e.information).eigenvalues().minCoeff(), 0.0);
  }
}

TEST(SlamRun, WritesEveryOutputAndRunJson) {
  const Sequence seq = Sequence::open(corridorSequence());
  const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  const SlamResult r = runSlam(seq, config);
  const fs::path out = test::scratchDir() / "run";
  const RunSummary s = writeRunOutputs(seq, r, config, OutputConfig{}, out);
  for (const char* f : {"trajectory.kitti", "trajectory.tum", "odometry_only.kitti", "graph.g2o",
                        "map.ply", "map.pcd", "hazards.json", "hazards.csv", "map_top.png",
                        "trajectory.png", "viewer.html", "run.json"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  const std::string summary = formatRunSummary(r, s, out, OutputConfig{});
  EXPECT_NE(summary.find("viewer.html"), std::string::npos) << summary;
  EXPECT_NE(summary.find("Map error"), std::string::npos) << summary;
  EXPECT_EQ(readKittiTrajectory(out / "trajectory.kitti").size(), seq.size());
  const auto j = readJson(out / "run.json");
  EXPECT_EQ(j["method"], "property-icp+pgo");
  EXPECT_EQ(j["frames"], seq.size());
  EXPECT_TRUE(j.contains("map_error"));
  EXPECT_GT(j["frames_per_s"].get<double>(), 0.0);
  // Parameters: nested objects in the YAML layout (not YAML text in strings), read back exactly.
  const auto& p = j["parameters"];
  EXPECT_EQ(p["odometry"]["registration"]["max_iterations"], config.odometry.registration.max_iterations);
  EXPECT_EQ(p["loop_closure"]["verification"]["registration"]["index"], "kdtree");
  EXPECT_EQ(p["slam"]["keyframe_distance"], config.keyframe_distance);
  SlamConfig reread = SlamConfig::forMethod(SlamMethod::Icp);
  reread.applyYamlString(jsonToYaml(p), "run.json");
  EXPECT_EQ(configToJson(reread), configToJson(config));
  ASSERT_TRUE(s.map_error.has_value());
  EXPECT_LT(s.map_error->point.mean, 1.0);
  EXPECT_GT(s.hazards, 0u);  // the corridor has heat and water patches
  // No temporary files left behind.
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(SlamRun, BadInputIsAOneLineError) {
  const fs::path dir = test::scratchDir();
  // odometry method on a sequence without odometry.txt
  fs::create_directories(dir / "seq/velodyne");
  fs::copy_file(corridorSequence() / "velodyne/000000.bin", dir / "seq/velodyne/000000.bin");
  const Sequence seq = Sequence::open(dir / "seq");
  try {
    runSlam(seq, SlamConfig::forMethod(SlamMethod::Odometry));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("odometry.txt"), std::string::npos) << e.what();
  }
  SlamConfig bad = SlamConfig::forMethod(SlamMethod::Icp);
  bad.keyframe_distance = -1;
  EXPECT_THROW(bad.validate(), Error);
  std::ofstream(dir / "bad.yaml") << "slam: {keyframe_distanse: 2}\n";
  SlamConfig c;
  try {
    c.applyYamlFile(dir / "bad.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe_distanse"), std::string::npos) << e.what();
  }
}

TEST(RunCli, RunsAndRejectsBadInput) {
  const fs::path out = test::scratchDir() / "cli-out";
  auto r = test::runCli("run " + corridorSequence().string() + " --method property-icp --out " +
                        out.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(out / "run.json"));
  r = test::runCli("run " + corridorSequence().string() + " --method nope --out " + out.string() + "2");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("unknown method 'nope'"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out.string() + "2"));
  r = test::runCli("run /nonexistent/seq --out " + out.string() + "3");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("/nonexistent/seq"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
}

TEST(RunCli, KittiSampleGivesAMapAndAHazardInventory) {
  // Real HDL-64 scans with SemanticKITTI labels (no ground truth, no wheel odometry):
  // poles, trunks and signs stand in for the hazards.
  const fs::path out = test::scratchDir() / "kitti";
  auto r = test::runCli("run " + test::sharedData("kitti-semantic-sample").string() +
                        " --classes semantic-kitti --method property-icp --quiet --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto hazards = readJson(out / "hazards.json");
  ASSERT_GT(hazards["count"].get<int>(), 0);
  bool pole = false;
  for (const auto& h : hazards["hazards"]) pole |= h["class"] == "heat";  // poles map to heat
  EXPECT_TRUE(pole);
  const auto traj = readKittiTrajectory(out / "trajectory.kitti");
  ASSERT_EQ(traj.size(), 6u);
  // KITTI's car moves forward ~0.7 m per frame in these scans.
  const double step = (traj.poses[1].translation() - traj.poses[0].translation()).norm();
  EXPECT_GT(step, 0.4);
  EXPECT_LT(step, 1.2);
}

TEST(Demo, BothSetUpsWriteTheTableAndOutputs) {
  const fs::path dir = test::scratchDir();
  DemoConfig c;
  c.out_dir = dir;
  c.scenario = "corridor";
  c.frames = 12;
  c.progress = false;
  std::ostringstream log;
  const DemoReport report = runDemo(c, log);
  ASSERT_EQ(report.rows.size(), 5u);
  ASSERT_EQ(report.map_rows.size(), 5u);
  EXPECT_EQ(report.rows[1].tracking, OdometryMode::FrameToFrame);
  EXPECT_EQ(report.map_rows[1].tracking, OdometryMode::FrameToMap);
  const nlohmann::json t = readJson(dir / "table2.json");
  for (const char* m : {"odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo"}) {
    for (const char* k : {"map_error_m", "ate_m", "frames_per_s"}) {
      EXPECT_TRUE(t.at(m).at(k).is_number()) << m << " " << k;
      EXPECT_TRUE(t.at("frame_to_map").at(m).at(k).is_number()) << m << " " << k;
    }
    EXPECT_TRUE(fs::exists(dir / m / "map.ply")) << m;
    EXPECT_TRUE(fs::exists(dir / "frame-to-map" / m / "trajectory.kitti")) << m;
    EXPECT_TRUE(fs::exists(dir / m / "viewer.html")) << m;
  }
  // index.html links every method's viewer beside Table 2; the error plot is there.
  const std::string index = readTextFile(dir / "index.html");
  EXPECT_NE(index.find("href=\"property-icp+pgo/viewer.html\""), std::string::npos);
  EXPECT_NE(index.find("href=\"frame-to-map/icp/viewer.html\""), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "trajectory_error.png"));
  EXPECT_TRUE(fs::exists(dir / "trajectory_error_frame_to_map.png"));
  // ICP must beat the drifting encoders on any sequence, in both set-ups
  EXPECT_LT(report.rows[1].map_error_m, report.rows[0].map_error_m);
  EXPECT_LT(report.map_rows[3].map_error_m, report.map_rows[0].map_error_m);
  EXPECT_TRUE(fs::exists(dir / "maps_side_by_side.png"));
  EXPECT_TRUE(fs::exists(dir / "maps_side_by_side_frame_to_map.png"));
  const std::string table = formatTable2(report);
  EXPECT_NE(table.find("paper's set-up"), std::string::npos);
  EXPECT_NE(table.find("Proposed ICP with pose graph optimization"), std::string::npos);
  // The rows on labels from the simulated thermal camera (issue 16).
  ASSERT_EQ(report.camera_rows.size(), 2u);
  EXPECT_EQ(report.camera_rows[0].method, SlamMethod::PropertyIcp);
  EXPECT_TRUE(t.at("camera_labels").at("property-icp+pgo").at("map_error_m").is_number());
  EXPECT_TRUE(fs::exists(dir / "camera-labels" / "property-icp" / "map.ply"));
  EXPECT_NE(table.find("camera labels"), std::string::npos);
  fs::remove_all(dir);
}
