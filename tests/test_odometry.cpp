// Odometry: KITTI scans with SemanticKITTI labels, synthetic runs with wheel odometry, failure
// fallbacks, bad input, the local map, and the register / odometry CLIs.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <unordered_map>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/odometry/detail/voxel_key_index.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"
#include "test_helpers.hpp"
#include "test_registration_scenes.hpp"

using namespace hazmap;
using hazmap::test::rotErrDeg;
using hazmap::test::transErr;

// Property-ICP and plain ICP agree within a few cm on frames 0→1→2, and the labels visibly change
// which points are paired.
TEST(KittiSemantic, PropertyAndPlainIcpAgree) {
  const ClassTable table = ClassTable::semanticKitti();
  const VoxelDownsampleConfig vd = propertyVoxels(0.5);
  std::vector<LabeledCloud> scans;
  for (int i = 0; i < 3; ++i) scans.push_back(voxelDownsample(test::kittiScan(i, table), vd, table));
  Eigen::Isometry3d chain_plain = Eigen::Isometry3d::Identity(), chain_prop = Eigen::Isometry3d::Identity();
  for (int i = 1; i < 3; ++i) {
    RegistrationConfig cfg;
    cfg.use_classes = false;
    const auto plain = registerClouds(scans[i], scans[i - 1], Eigen::Isometry3d::Identity(), table, cfg);
    cfg.use_classes = true;
    const auto prop = registerClouds(scans[i], scans[i - 1], Eigen::Isometry3d::Identity(), table, cfg);
    ASSERT_TRUE(plain.converged) << plain.reason;
    ASSERT_TRUE(prop.converged) << prop.reason;
    chain_plain = chain_plain * plain.transform;
    chain_prop = chain_prop * prop.transform;
    const auto& sp = plain.stats;
    const auto& sq = prop.stats;
    std::printf("KITTI %d->%d: motion %.3f m; plain vs property %.4f m %.4f deg\n"
                "  property points %zu: same-class partner plain %zu (%.1f%%), property %zu (%.1f%%, "
                "%zu beyond 1 m); cross-class pairs plain %zu, property %zu\n",
                i, i - 1, prop.transform.translation().norm(), transErr(plain.transform, prop.transform),
                rotErrDeg(plain.transform, prop.transform), sq.property_points, sp.property_matched,
                100.0 * sp.property_matched / std::max<std::size_t>(1, sp.property_points),
                sq.property_matched, 100.0 * sq.property_matched / std::max<std::size_t>(1, sq.property_points),
                sq.wide_matches, sp.cross_class, sq.cross_class);
    EXPECT_LT(transErr(plain.transform, prop.transform), 0.03);
    EXPECT_LT(rotErrDeg(plain.transform, prop.transform), 0.1);
    EXPECT_GT(prop.transform.translation().norm(), 0.5);  // the car moves ~0.7 m per frame
    EXPECT_GT(sq.property_points, 50u);
    // the paper's rule pairs labelled points with their own class far more often
    EXPECT_GT(sq.property_matched, sp.property_matched);
    EXPECT_LT(sq.cross_class, sp.cross_class);
  }
  EXPECT_LT(transErr(chain_plain, chain_prop), 0.03);
}

namespace {

// A synthetic drive through the room/corridor scene: scans are surface samples seen from the
// sensor pose (no occlusion), wheel odometry has 5 % translation and 0.5°/frame yaw error.
struct SyntheticRun {
  std::vector<LabeledCloud> scans;
  std::vector<Eigen::Isometry3d> truth, wheel;
};

SyntheticRun syntheticRun(const std::vector<hazmap::test::Patch>& scene, int frames, double step,
                          unsigned seed, std::size_t points = 6000) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  SyntheticRun run;
  Eigen::Isometry3d pose = fromXyzRpy(-6.0, 0.0, 1.0, 0, 0, 0), odom = pose;
  for (int i = 0; i < frames; ++i) {
    if (i > 0) {
      const Eigen::Isometry3d inc = fromXyzRpy(step, 0.02 * std::sin(i), 0, 0, 0, 0.01 * std::cos(i));
      pose = pose * inc;
      const Eigen::Isometry3d noisy =
          fromXyzRpy(step * (1.0 + 0.05 * g(rng)), inc.translation().y() + 0.02 * g(rng), 0, 0, 0,
                     yawOf(inc) + 0.5 * M_PI / 180.0 * g(rng));
      odom = odom * noisy;
    }
    run.truth.push_back(pose);
    run.wheel.push_back(odom);
    run.scans.push_back(hazmap::test::samplePatches(scene, points, rng, 0.01, pose.inverse()));
  }
  return run;
}

}  // namespace

class SyntheticOdometry : public ::testing::TestWithParam<std::tuple<OdometryMode, bool>> {};

TEST_P(SyntheticOdometry, TracksWithWheelGuess) {
  const auto [mode, use_classes] = GetParam();
  const auto run = syntheticRun(hazmap::test::roomScene(), 10, 0.6, 17);
  OdometryConfig cfg;
  cfg.mode = mode;
  cfg.registration.use_classes = use_classes;
  cfg.voxel_size = 0.2;
  cfg.min_range = 0.0;
  Odometry odo(ClassTable::defaults(), cfg, run.truth[0]);
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    std::optional<Eigen::Isometry3d> inc;
    if (i > 0) inc = run.wheel[i - 1].inverse() * run.wheel[i];
    const auto& f = odo.addFrame(run.scans[i], inc);
    EXPECT_NE(f.status, FrameStatus::Fallback) << i << ": " << f.reason;
    EXPECT_EQ(f.wheel_guess, i > 0);
  }
  const double err_odo = transErr(odo.frames().back().pose, run.truth.back());
  const double err_wheel = transErr(run.truth[0] * run.wheel[0].inverse() * run.wheel.back(), run.truth.back());
  std::printf("synthetic %s %s: final error %.4f m (wheel odometry %.3f m)\n", toString(mode),
              use_classes ? "property" : "plain", err_odo, err_wheel);
  EXPECT_LT(err_odo, 0.03);
  EXPECT_EQ(odo.trajectory().size(), run.scans.size());
  // covariances are usable information matrices
  for (std::size_t i = 1; i < odo.frames().size(); ++i) {
    const Matrix6d& c = odo.frames()[i].covariance;
    EXPECT_TRUE(c.allFinite());
    EXPECT_GT(c.diagonal().minCoeff(), 0.0);
  }
}

INSTANTIATE_TEST_SUITE_P(All, SyntheticOdometry,
                         ::testing::Combine(::testing::Values(OdometryMode::FrameToFrame,
                                                              OdometryMode::FrameToMap),
                                            ::testing::Bool()));

TEST(Odometry, ConstantVelocityWithoutWheel) {
  const auto run = syntheticRun(hazmap::test::roomScene(), 8, 0.5, 3);
  OdometryConfig cfg;
  cfg.voxel_size = 0.2;
  cfg.min_range = 0.0;
  Odometry odo(ClassTable::defaults(), cfg, run.truth[0]);
  for (const auto& s : run.scans) odo.addFrame(s);
  for (std::size_t i = 1; i < run.scans.size(); ++i) {
    EXPECT_FALSE(odo.frames()[i].wheel_guess);
    EXPECT_NE(odo.frames()[i].status, FrameStatus::Fallback) << odo.frames()[i].reason;
  }
  // frame 2 onwards guessed the previous increment
  EXPECT_TRUE(odo.frames()[2].guess.isApprox(odo.frames()[1].increment));
  EXPECT_LT(transErr(odo.frames().back().pose, run.truth.back()), 0.03);
}

TEST(Odometry, FailuresFallBackWithAReason) {
  const auto run = syntheticRun(hazmap::test::roomScene(), 4, 0.5, 5);
  OdometryConfig cfg;
  cfg.mode = OdometryMode::FrameToFrame;
  cfg.voxel_size = 0.2;
  cfg.min_range = 0.0;
  Odometry odo(ClassTable::defaults(), cfg, run.truth[0]);
  odo.addFrame(run.scans[0]);
  // an empty scan: nothing to register
  const Eigen::Isometry3d inc = run.wheel[0].inverse() * run.wheel[1];
  const auto& f1 = odo.addFrame(LabeledCloud{}, inc);
  EXPECT_EQ(f1.status, FrameStatus::Fallback);
  EXPECT_EQ(f1.reason, "empty source cloud");
  EXPECT_TRUE(f1.increment.isApprox(inc));
  EXPECT_NEAR(f1.covariance(0, 0), cfg.fallback_sigma_translation * cfg.fallback_sigma_translation, 1e-12);
  {
    // after an empty scan the next one registers against the last non-empty scan (frame 0)
    Odometry again(ClassTable::defaults(), cfg, run.truth[0]);
    again.addFrame(run.scans[0]);
    again.addFrame(LabeledCloud{}, inc);
    const auto& f = again.addFrame(run.scans[2], run.wheel[1].inverse() * run.wheel[2]);
    EXPECT_EQ(f.status, FrameStatus::Tracked) << f.reason;
    EXPECT_LT(transErr(f.pose, run.truth[2]), 0.03);
  }
  // a scan of a completely different place: low fitness or divergence
  std::mt19937 rng(1);
  const auto elsewhere = hazmap::test::samplePatches(hazmap::test::corridorScene(), 6000, rng, 0.01,
                                                     fromXyzRpy(0, 0, -30, 0, 0, 0));
  const auto& f2 = odo.addFrame(elsewhere, inc);
  EXPECT_EQ(f2.status, FrameStatus::Fallback);
  EXPECT_NE(f2.reason.find("correspondences"), std::string::npos) << f2.reason;
  std::printf("fallback reasons: '%s' / '%s'\n", odo.frames()[1].reason.c_str(), odo.frames()[2].reason.c_str());
}

TEST(Odometry, CorridorKeepsTheGuessAlongTheAxis) {
  // Plain ICP in a featureless corridor: degenerate along x, the wheel odometry is kept there.
  const auto run = syntheticRun(hazmap::test::corridorScene(40.0, false), 4, 0.5, 8, 8000);
  OdometryConfig cfg;
  cfg.mode = OdometryMode::FrameToFrame;
  cfg.registration.use_classes = false;
  cfg.voxel_size = 0.2;
  cfg.min_range = 0.0;
  Odometry odo(ClassTable::defaults(), cfg, run.truth[0]);
  for (std::size_t i = 0; i < run.scans.size(); ++i) {
    std::optional<Eigen::Isometry3d> inc;
    if (i > 0) inc = run.wheel[i - 1].inverse() * run.wheel[i];
    const auto& f = odo.addFrame(run.scans[i], inc);
    if (i == 0) continue;
    EXPECT_EQ(f.status, FrameStatus::Degenerate) << f.reason;
    EXPECT_NEAR(f.increment.translation().x(), inc->translation().x(), 0.02);  // the guess's x
    EXPECT_GT(f.covariance(0, 0), 0.5 * cfg.fallback_sigma_translation * cfg.fallback_sigma_translation);
  }
}

TEST(Odometry, DenseLidarPresetOnTheKittiSample) {
  // The shipped preset for 64/128-beam sensors (config/odometry/dense_lidar.yaml) against the
  // defaults on the six KITTI scans (labels where the sample has them): same trajectory within
  // a few cm, every frame registered, a map a fraction of the size (docs/registration.md).
  const OdometryConfig preset =
      loadOdometryConfig(hazmap::test::sourceDir("config/odometry/dense_lidar.yaml").string());
  EXPECT_DOUBLE_EQ(preset.source_voxel_size, 1.0);
  EXPECT_DOUBLE_EQ(preset.map.min_point_distance, 0.5);
  EXPECT_EQ(preset.map.normal_updates, 1);
  EXPECT_EQ(preset.mode, OdometryMode::FrameToMap);
  const ClassTable table = ClassTable::semanticKitti();
  const auto dir = hazmap::test::sharedData("kitti-semantic-sample");
  Odometry fast(table, preset), reference(table, OdometryConfig::defaults());
  for (int i = 0; i < 6; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%06d", i);
    const auto label = dir / "labels" / (std::string(name) + ".label");
    const LabeledCloud scan = readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"),
                                            std::filesystem::exists(label) ? std::optional(label) : std::nullopt,
                                            table);
    const OdometryFrame& f = fast.addFrame(scan);
    const OdometryFrame& r = reference.addFrame(scan);
    if (i > 0) {
      EXPECT_EQ(f.status, FrameStatus::Tracked) << "frame " << i << ": " << f.reason;
      EXPECT_LT(f.source_points, r.source_points / 2) << "frame " << i;
    }
    EXPECT_LT(transErr(f.pose, r.pose), 0.03) << "frame " << i;
    EXPECT_LT(rotErrDeg(f.pose, r.pose), 0.1) << "frame " << i;
  }
  EXPECT_GT(fast.frames().back().pose.translation().x(), 3.0);  // ~0.7 m per frame forward
  EXPECT_LT(fast.frames().back().map_points * 2, reference.frames().back().map_points);
}

TEST(Odometry, BadInput) {
  const ClassTable table = ClassTable::defaults();
  OdometryConfig cfg;
  Odometry odo(table, cfg);
  LabeledCloud scan;
  scan.push_back({5, 0, 0}, 7);  // class 7 is not in the table
  EXPECT_THROW(odo.addFrame(scan), Error);
  LabeledCloud ok;
  ok.push_back({5, 0, 0}, 0);
  odo.addFrame(ok);
  Eigen::Isometry3d nan_inc = Eigen::Isometry3d::Identity();
  nan_inc(1, 3) = NAN;
  EXPECT_THROW(odo.addFrame(ok, nan_inc), Error);
  OdometryConfig bad;
  bad.voxel_size = 0.0;
  EXPECT_THROW(Odometry(table, bad), Error);
  bad = {};
  bad.map.max_points_per_voxel = 0;
  EXPECT_THROW(Odometry(table, bad), Error);
  EXPECT_THROW(odometryConfigFromYaml("mode: sideways\n", "odo.yaml"), Error);
  EXPECT_THROW(odometryConfigFromYaml("map:\n  bogus: 1\n", "odo.yaml"), Error);
  const auto c = odometryConfigFromYaml("mode: frame\nmap:\n  voxel_size: 0.7\nregistration:\n  metric: point\n", "x");
  EXPECT_EQ(c.mode, OdometryMode::FrameToFrame);
  EXPECT_DOUBLE_EQ(c.map.voxel_size, 0.7);
  EXPECT_EQ(c.registration.metric, IcpMetric::PointToPoint);
}

TEST(LocalMap, VoxelKeyIndexAgreesWithUnorderedMapUnderChurn) {
  // The map adds and drops voxels every frame: random inserts/erases over a small key range (so
  // probe runs collide and wrap), checked against std::unordered_map after every operation.
  detail::VoxelKeyIndex index;
  std::unordered_map<std::uint64_t, std::uint32_t> ref;
  std::mt19937_64 rng(7);
  for (int op = 0; op < 200000; ++op) {
    const std::uint64_t key = rng() % 3000;
    if (rng() % 3 == 0) {
      index.erase(key);
      ref.erase(key);
    } else {
      const auto value = static_cast<std::uint32_t>(op);
      const auto [slot, added] = index.tryEmplace(key, value);
      const auto [it, ref_added] = ref.try_emplace(key, value);
      ASSERT_EQ(added, ref_added);
      ASSERT_EQ(*slot, it->second);
    }
    ASSERT_EQ(index.size(), ref.size());
    const std::uint64_t probe = rng() % 3000;
    const std::uint32_t* found = index.find(probe);
    const auto it = ref.find(probe);
    ASSERT_EQ(found != nullptr, it != ref.end()) << "key " << probe << " after op " << op;
    if (found) ASSERT_EQ(*found, it->second);
  }
  for (const auto& [k, v] : ref) ASSERT_TRUE(index.find(k) && *index.find(k) == v);
  index.clear();
  EXPECT_EQ(index.find(1), nullptr);
}

TEST(LocalMap, BoundedAndKeepsPropertyPoints) {
  const ClassTable table = ClassTable::defaults();
  LocalMapConfig mc;
  mc.voxel_size = 1.0;
  mc.max_points_per_voxel = 4;
  mc.max_distance = 10.0;
  LocalMap map(mc);
  LabeledCloud scan;
  for (int k = 0; k < 10; ++k) scan.push_back({0.05f * k, 0.5f, 0.5f}, 0);
  scan.push_back({0.9f, 0.9f, 0.9f}, 1);  // a heat point arriving in a full voxel
  scan.push_back({50.f, 0.f, 0.f}, 0);    // far away: dropped with its voxel
  map.integrate(scan, Eigen::Vector3d::Zero(), table);
  const LabeledCloud c = map.cloud();
  EXPECT_EQ(c.size(), 4u);
  EXPECT_EQ(std::count(c.classes.begin(), c.classes.end(), ClassId(1)), 1);
  // moving away drops the voxel
  map.integrate(LabeledCloud{}, Eigen::Vector3d(100, 0, 0), table);
  EXPECT_TRUE(map.empty());
}

TEST(Cli, RegisterJsonOnTheScanPair) {
  const auto d = hazmap::test::sharedData("scan-pair");
  const auto r = hazmap::test::runCli("register " + (d / "251371071.pcd").string() + " " +
                                      (d / "251370668.pcd").string() + " --voxel 0.25 --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(r.output);
  ASSERT_EQ(j["transform"].size(), 16u);
  ASSERT_EQ(j["covariance"].size(), 36u);
  EXPECT_TRUE(j["converged"].get<bool>());
  EXPECT_GT(j["fitness"].get<double>(), 0.8);
  EXPECT_GT(j["iterations"].get<int>(), 0);
  EXPECT_NEAR(j["transform"][3].get<double>(), 0.4857, 0.05);
  EXPECT_DOUBLE_EQ(j["transform"][15].get<double>(), 1.0);
  // --init with the printed transform converges at once to the same place
  const auto dir = hazmap::test::scratchDir();
  std::ofstream init(dir / "init.txt");
  for (int k = 0; k < 16; ++k) init << j["transform"][k].get<double>() << (k % 4 == 3 ? "\n" : " ");
  init.close();
  const auto r2 = hazmap::test::runCli("register " + (d / "251371071.pcd").string() + " " +
                                       (d / "251370668.pcd").string() + " --voxel 0.25 --method icp --init " +
                                       (dir / "init.txt").string());
  ASSERT_EQ(r2.exit_code, 0) << r2.output;
  EXPECT_NE(r2.output.find("converged"), std::string::npos);
}

TEST(Cli, RegisterBadInput) {
  const auto d = hazmap::test::sharedData("scan-pair");
  const auto dir = hazmap::test::scratchDir();
  const std::string pair = (d / "251371071.pcd").string() + " " + (d / "251370668.pcd").string();
  auto r = hazmap::test::runCli("register " + (dir / "missing.pcd").string() + " " + (d / "251370668.pcd").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("missing.pcd"), std::string::npos) << r.output;
  writeTextAtomically(dir / "bad.txt", "1 0 0 0\n0 1 0 0\n0 0 1 nan\n0 0 0 1\n");
  r = hazmap::test::runCli("register " + pair + " --init " + (dir / "bad.txt").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("bad.txt"), std::string::npos) << r.output;
  r = hazmap::test::runCli("register " + pair + " --method magic");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("--method"), std::string::npos) << r.output;
  r = hazmap::test::runCli("register " + pair + " --max-distance -1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("max_correspondence_distance"), std::string::npos) << r.output;
}

TEST(Cli, OdometryOnTheKittiSample) {
  const auto dir = hazmap::test::scratchDir();
  const auto seq = hazmap::test::sharedData("kitti-semantic-sample");
  const auto r = hazmap::test::runCli("odometry " + seq.string() + " --classes semantic-kitti --mode frame "
                                      "--method property-icp --max-frames 3 --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Trajectory kitti = readKittiTrajectory(dir / "poses.txt");
  const Trajectory tum = readTumTrajectory(dir / "poses_tum.txt");
  ASSERT_EQ(kitti.size(), 3u);
  ASSERT_EQ(tum.size(), 3u);
  EXPECT_NEAR(kitti.poses[2].translation().x(), 1.36, 0.1);  // ~0.68 m per frame forward
  EXPECT_LT(transErr(kitti.poses[2], tum.poses[2]), 1e-4);
  const std::string csv = readTextFile(dir / "frames.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4);
  const auto summary = nlohmann::json::parse(readTextFile(dir / "summary.json"));
  EXPECT_EQ(summary["frames"].get<int>(), 3);
  EXPECT_EQ(summary["fallbacks"].get<int>(), 0);
  const std::string cov = readTextFile(dir / "covariances.txt");
  EXPECT_EQ(std::count(cov.begin(), cov.end(), '\n'), 4);
  // bad arguments
  auto bad = hazmap::test::runCli("odometry " + seq.string() + " --mode sideways --out " + dir.string());
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.output.find("--mode"), std::string::npos);
  bad = hazmap::test::runCli("odometry " + (dir / "nowhere").string() + " --out " + dir.string());
  EXPECT_EQ(bad.exit_code, 1);
}

// What a user types first: no --classes. The folder is recognised as SemanticKITTI (a notice
// says so, naming the label file), and the run is the one with --classes semantic-kitti.
TEST(Cli, OdometryOnTheKittiSampleWithDefaults) {
  const auto seq = hazmap::test::sharedData("kitti-semantic-sample");
  const auto dir = hazmap::test::scratchDir();
  const auto r = hazmap::test::runCli("odometry " + seq.string() + " --max-frames 3 --out " + (dir / "a").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("labels/000000.label holds SemanticKITTI label ids"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("not in the class table"), std::string::npos) << r.output;
  const auto named = hazmap::test::runCli("odometry " + seq.string() + " --classes semantic-kitti --max-frames 3 --out " +
                                          (dir / "b").string());
  ASSERT_EQ(named.exit_code, 0) << named.output;
  EXPECT_EQ(named.output.find("SemanticKITTI label ids"), std::string::npos) << named.output;
  EXPECT_EQ(readTextFile(dir / "a/poses.txt"), readTextFile(dir / "b/poses.txt"));
  EXPECT_EQ(readKittiTrajectory(dir / "a/poses.txt").size(), 3u);
}
