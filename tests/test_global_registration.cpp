// Global registration (issue 19) on real scans — KITTI, the scan pair, the VLP-16 and Ouster
// recordings — and on the simulated naraha scans with property classes: known jumps (yaw up to
// 180°, metres of translation) recovered without an initial guess; bad input and ambiguity.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/registration/correlative_search.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "hazmap/io/transform_file.hpp"
#include "test_helpers.hpp"
#include "test_registration_scenes.hpp"

using namespace hazmap;
using hazmap::test::rotErrDeg;
using hazmap::test::transErr;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// A jump a slipping, spinning crawler could make: yaw uniform in ±max_yaw, a horizontal
/// translation of up to max_translation, a little roll/pitch and height.
Eigen::Isometry3d randomJump(std::mt19937& rng, double max_yaw_deg, double max_translation) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double yaw = u(rng) * max_yaw_deg * kDeg;
  const double heading = u(rng) * std::numbers::pi;
  const double dist = 0.5 * (u(rng) + 1.0) * max_translation;
  Eigen::Isometry3d J = Eigen::Isometry3d::Identity();
  J.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.02 * u(rng), Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(0.02 * u(rng), Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  J.translation() = Eigen::Vector3d(dist * std::cos(heading), dist * std::sin(heading), 0.1 * u(rng));
  return J;
}

struct Trials {
  int runs = 0, correct = 0, wrong_accepted = 0;
  double worst_ms = 0.0;
};

/// Registers `source` to `target` moved by `trials` random jumps (the target is moved, with its
/// viewpoint, so the source keeps its sensor at the origin as a live scan does). `reference` =
/// target ← source before the jump. Correct = accepted within 0.2 m / 1° of jump · reference.
Trials runTrials(const LabeledCloud& source, const LabeledCloud& target, const Eigen::Isometry3d& reference,
                 const ClassTable& table, const GlobalRegistrationConfig& cfg, int trials, double max_yaw_deg,
                 double max_translation, unsigned seed) {
  std::mt19937 rng(seed);
  Trials t;
  for (int k = 0; k < trials; ++k) {
    const Eigen::Isometry3d J = randomJump(rng, max_yaw_deg, max_translation);
    const auto prepared = prepareGlobalTarget(target.transformed(J), table, cfg, J.translation().cast<float>());
    const auto r = registerGlobally(source, prepared, table, cfg);
    const Eigen::Isometry3d truth = J * reference;
    const bool close = transErr(r.transform, truth) < 0.2 && rotErrDeg(r.transform, truth) < 1.0;
    ++t.runs;
    t.correct += r.success && close;
    t.wrong_accepted += r.success && !close;
    t.worst_ms = std::max(t.worst_ms, r.timings.total_ms);
    std::printf("  %s pts %zu feat %zu corr %zu inl %zu score %.3f/%.3f  prep %.1f match %.1f hyp %.1f refine %.1f total %.1f err %.3f %.2f\n",
                r.success ? "ok " : "NOK", r.source_points, r.source_features, r.correspondences, r.inliers, r.score,
                r.second_best_score, r.timings.prepare_ms, r.timings.match_ms, r.timings.hypotheses_ms,
                r.timings.refine_ms, r.timings.total_ms, transErr(r.transform, truth), rotErrDeg(r.transform, truth));
  }
  return t;
}

LabeledCloud kitti(int i) { return hazmap::test::kittiScan(i, ClassTable::semanticKitti()); }

}  // namespace

TEST(GlobalRegistration, KittiRecoversLargeJumpsWithoutAGuess) {
  const ClassTable table = ClassTable::semanticKitti();
  const LabeledCloud target = kitti(0), source = kitti(2);
  // The reference: property ICP from identity (the scans are ≈ 1.4 m apart; it converges).
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.25;
  const auto icp = registerScans(source, target, Eigen::Isometry3d::Identity(), table, vd);
  ASSERT_TRUE(icp.converged);
  GlobalRegistrationConfig cfg;
  const Trials t = runTrials(source, target, icp.transform, table, cfg, 8, 180.0, 3.0, 7);
  std::printf("KITTI 0<-2, yaw ±180°, ≤ 3 m: %d/%d correct, %d wrong accepted, worst %.1f ms\n", t.correct, t.runs,
              t.wrong_accepted, t.worst_ms);
  EXPECT_GE(t.correct, 7);
  EXPECT_EQ(t.wrong_accepted, 0);
}

TEST(GlobalRegistration, ScanPairFindsTheReferenceWithoutAGuess) {
  const auto dir = hazmap::test::sharedData("scan-pair");
  const ClassTable table = ClassTable::defaults();
  const LabeledCloud target = readPcd(dir / "251370668.pcd", table);
  const LabeledCloud source = readPcd(dir / "251371071.pcd", table);
  const Eigen::Isometry3d reference = readTransformFile(dir / "relative.txt");
  const auto r = registerGlobally(source, target, table);
  std::printf("scan pair: %s, %.3f m / %.3f° from the reference, score %.3f (second %.3f), %.1f ms\n",
              r.success ? "accepted" : r.reason.c_str(), transErr(r.transform, reference),
              rotErrDeg(r.transform, reference), r.score, r.second_best_score, r.timings.total_ms);
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_LT(transErr(r.transform, reference), 0.1);
  EXPECT_LT(rotErrDeg(r.transform, reference), 0.5);
}

namespace {

struct NarahaPair {
  LabeledCloud source, target;
  Eigen::Isometry3d reference;
  ClassTable table;
};

const NarahaPair& narahaPair() {
  static const NarahaPair p = [] {
    sim::SimulatorConfig cfg;
    cfg.scenario = "naraha";
    cfg.seed = 3;
    cfg.max_frames = 60;
    const sim::Simulator sim(cfg);
    return NarahaPair{sim.scan(44), sim.scan(40), sim.groundTruth()[40].inverse() * sim.groundTruth()[44],
                      sim.classTable()};
  }();
  return p;
}

}  // namespace

TEST(GlobalRegistration, NarahaPlainAndPropertyAware) {
  const NarahaPair& p = narahaPair();
  for (bool classes : {false, true}) {
    GlobalRegistrationConfig cfg;
    cfg.use_classes = classes;
    const Trials t = runTrials(p.source, p.target, p.reference, p.table, cfg, 6, 180.0, 3.0, 11);
    std::printf("naraha 40<-44 %s: %d/%d correct, %d wrong accepted\n", classes ? "property" : "plain", t.correct,
                t.runs, t.wrong_accepted);
    EXPECT_GE(t.correct, 5);
    EXPECT_EQ(t.wrong_accepted, 0);
  }
}

namespace {

std::vector<LabeledCloud> readScans(const std::filesystem::path& path) {
  std::vector<LabeledCloud> out;
  auto src = openScanSource(path);
  while (auto s = src->next()) out.push_back(std::move(s->cloud));
  return out;
}

}  // namespace

TEST(GlobalRegistration, RealVlp16ScansRecoverJumps) {
  // The real VLP-16 bag (a small room, stationary sensor): scan 3 → scan 0 after the jumps.
  const auto scans = readScans(hazmap::test::sharedData("sensors/velodyne-vlp16"));
  ASSERT_EQ(scans.size(), 4u);
  const ClassTable table = ClassTable::defaults();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.2;
  const auto icp = registerScans(scans[3], scans[0], Eigen::Isometry3d::Identity(), table, vd);
  ASSERT_TRUE(icp.converged);
  const Trials t = runTrials(scans[3], scans[0], icp.transform, table, {}, 8, 180.0, 3.0, 21);
  std::printf("VLP-16 room 0<-3: %d/%d correct, %d wrong accepted\n", t.correct, t.runs, t.wrong_accepted);
  EXPECT_GE(t.correct, 7);
  EXPECT_EQ(t.wrong_accepted, 0);
}

TEST(GlobalRegistration, RealOusterScansMatchTheSdkPoses) {
  const auto dir = hazmap::test::sharedData("sensors/ouster-os1-128");
  const auto scans = readScans(dir / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  ASSERT_EQ(scans.size(), 3u);
  const auto poses = readKittiTrajectory(dir / "OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt").poses;
  ASSERT_EQ(poses.size(), 3u);
  const Eigen::Isometry3d reference = poses[0].inverse() * poses[2];
  const ClassTable table = ClassTable::defaults();
  // No guess at all, then a jump on top.
  const auto r = registerGlobally(scans[2], scans[0], table);
  std::printf("Ouster 0<-2: %s, %.3f m / %.2f° from ouster-sdk's poses, %.0f ms\n", r.success ? "accepted" : r.reason.c_str(),
              transErr(r.transform, reference), rotErrDeg(r.transform, reference), r.timings.total_ms);
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_LT(transErr(r.transform, reference), 0.1);
  EXPECT_LT(rotErrDeg(r.transform, reference), 0.5);
  const Trials t = runTrials(scans[2], scans[0], reference, table, {}, 3, 180.0, 3.0, 5);
  EXPECT_EQ(t.correct, 3);
}

// A rectangular room looks the same turned by 180°: plain global registration must call it
// ambiguous (never pick one at random); one heat source on one wall and a puddle off-centre
// break the symmetry for the property-aware variant.
TEST(GlobalRegistration, SymmetricRoomIsAmbiguousUntilPropertiesBreakTheTie) {
  using V = Eigen::Vector3d;
  std::vector<hazmap::test::Patch> room;
  room.push_back({V(-6, -4, 0), V(12, 0, 0), V(0, 8, 0), 0});
  room.push_back({V(-6, -4, 3), V(12, 0, 0), V(0, 8, 0), 0});
  room.push_back({V(-6, -4, 0), V(12, 0, 0), V(0, 0, 3), 0});
  room.push_back({V(-6, 4, 0), V(12, 0, 0), V(0, 0, 3), 0});
  room.push_back({V(-6, -4, 0), V(0, 8, 0), V(0, 0, 3), 0});
  room.push_back({V(6, -4, 0), V(0, 8, 0), V(0, 0, 3), 0});
  room.push_back({V(5.99, -1, 1), V(0, 1.2, 0), V(0, 0, 1.2), 1});  // heat on the +x wall
  room.push_back({V(-3, 1, 0.01), V(1.5, 0, 0), V(0, 1.5, 0), 2});  // puddle
  std::mt19937 rng(4);
  const LabeledCloud source = hazmap::test::samplePatches(room, 40000, rng, 0.01);
  Eigen::Isometry3d J = Eigen::Isometry3d::Identity();
  J.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  J.translation() = V(1.0, -0.5, 0.0);
  const LabeledCloud target = hazmap::test::samplePatches(room, 40000, rng, 0.01, J);
  const ClassTable table = ClassTable::defaults();

  GlobalRegistrationConfig plain;
  plain.use_classes = false;
  const auto p = registerGlobally(source, prepareGlobalTarget(target, table, plain, J.translation().cast<float>()),
                                  table, plain);
  EXPECT_FALSE(p.success);
  EXPECT_EQ(p.status, GlobalStatus::Ambiguous) << p.reason;
  EXPECT_TRUE(p.ambiguous);
  EXPECT_NE(p.reason.find("two distinct hypotheses"), std::string::npos) << p.reason;

  GlobalRegistrationConfig property;
  const auto q = registerGlobally(source, prepareGlobalTarget(target, table, property, J.translation().cast<float>()),
                                  table, property);
  ASSERT_TRUE(q.success) << q.reason;
  EXPECT_LT(transErr(q.transform, J), 0.1);
  EXPECT_LT(rotErrDeg(q.transform, J), 1.0);
  EXPECT_GT(q.label_agreement, 0.8);
  EXPECT_FALSE(q.ambiguous);  // the rival scores clearly less (global_registration.cpp, kAmbiguityRatio)
  EXPECT_LT(q.second_best_score, q.score);
}

TEST(GlobalRegistration, ABarePlaneIsNeverAccepted) {
  // Every in-plane motion fits a plane equally well.
  std::vector<hazmap::test::Patch> floor{{Eigen::Vector3d(-10, -10, -1.5), Eigen::Vector3d(20, 0, 0),
                                          Eigen::Vector3d(0, 20, 0), 0}};
  std::mt19937 rng(9);
  const LabeledCloud a = hazmap::test::samplePatches(floor, 20000, rng, 0.01);
  const LabeledCloud b = hazmap::test::samplePatches(floor, 20000, rng, 0.01);
  const auto r = registerGlobally(a, b, ClassTable::defaults());
  EXPECT_FALSE(r.success) << "accepted a plane: score " << r.score << " second " << r.second_best_score;
  EXPECT_TRUE(r.status == GlobalStatus::Degenerate || r.status == GlobalStatus::Ambiguous) << r.reason;
  EXPECT_FALSE(r.reason.empty());
}

TEST(GlobalRegistration, TooFewPointsSaySo) {
  LabeledCloud tiny;
  for (int i = 0; i < 20; ++i) tiny.push_back(Eigen::Vector3f(static_cast<float>(i), 0.0f, 0.0f));
  const LabeledCloud scan = kitti(0);
  const ClassTable table = ClassTable::semanticKitti();
  const auto r = registerGlobally(tiny, scan, table);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.status, GlobalStatus::TooFewPoints);
  EXPECT_NE(r.reason.find("too few source points: 20 < 50"), std::string::npos) << r.reason;
  const auto empty = registerGlobally(scan, LabeledCloud{}, table);
  EXPECT_EQ(empty.status, GlobalStatus::TooFewPoints);
  EXPECT_NE(empty.reason.find("too few target points: 0"), std::string::npos) << empty.reason;
  // Points enough, features not: a thin line of points has no surface to describe.
  LabeledCloud line;
  for (int i = 0; i < 400; ++i) line.push_back(Eigen::Vector3f(0.5f * static_cast<float>(i), 0.0f, 0.0f));
  const auto l = registerGlobally(line, line, table);
  EXPECT_FALSE(l.success);
  EXPECT_EQ(l.status, GlobalStatus::TooFewFeatures) << l.reason;
}

TEST(GlobalRegistration, NonFinitePointsAreIgnored) {
  const NarahaPair& p = narahaPair();
  LabeledCloud source = p.source;
  for (std::size_t i = 0; i < source.size(); i += 50) source.points[i].x() = std::numeric_limits<float>::quiet_NaN();
  const auto r = registerGlobally(source, p.target, p.table);
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_LT(transErr(r.transform, p.reference), 0.2);
}

TEST(GlobalRegistration, ConfigReadsValidatesAndChecksTheTarget) {
  const auto c = globalRegistrationConfigFromYaml(
      "global_registration:\n  voxel_size: 0.4\n  use_classes: false\n  refinement:\n    max_iterations: 12\n", "g.yaml");
  EXPECT_DOUBLE_EQ(c.voxel_size, 0.4);
  EXPECT_FALSE(c.use_classes);
  EXPECT_EQ(c.refinement.max_iterations, 12);
  EXPECT_EQ(c.refinement.max_source_points, RefinementIcpOverrides{}.max_source_points);
  try {
    globalRegistrationConfigFromYaml("voxel_sise: 0.4\n", "g.yaml");
    FAIL() << "unknown key accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("voxel_size"), std::string::npos) << e.what();
  }
  GlobalRegistrationConfig bad;
  bad.feature_radius = 0.3;  // below the voxel
  EXPECT_THROW(bad.validate(), Error);
  bad = {};
  bad.min_overlap = 1.5;
  EXPECT_THROW(bad.validate(), Error);
  // A target prepared with other feature settings is refused, not silently mismatched.
  const NarahaPair& p = narahaPair();
  const auto target = prepareGlobalTarget(p.target, p.table);
  GlobalRegistrationConfig other;
  other.feature_radius = 2.0;
  EXPECT_THROW(registerGlobally(p.source, target, p.table, other), Error);
}

TEST(GlobalRegistration, SameAnswerForAnyNumberOfThreads) {
  const NarahaPair& p = narahaPair();
  GlobalRegistrationConfig one, two;
  one.threads = 1;
  two.threads = 2;
  const auto a = registerGlobally(p.source, p.target, p.table, one);
  const auto b = registerGlobally(p.source, p.target, p.table, two);
  EXPECT_TRUE(a.transform.matrix() == b.transform.matrix());
  EXPECT_EQ(a.correspondences, b.correspondences);
  EXPECT_EQ(a.score, b.score);
}

TEST(GlobalRegistration, Cli) {
  const auto dir = hazmap::test::sharedData("scan-pair");
  const std::string pair = (dir / "251371071.pcd").string() + " " + (dir / "251370668.pcd").string();
  const auto ok = hazmap::test::runCli("register " + pair + " --global --json");
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("\"status\": \"success\""), std::string::npos) << ok.output;
  const auto init = hazmap::test::runCli("register " + pair + " --global --init " + (dir / "relative.txt").string());
  EXPECT_NE(init.exit_code, 0);
  EXPECT_NE(init.output.find("--init"), std::string::npos) << init.output;
  const auto set = hazmap::test::runCli("register " + pair + " --global --set ransac_iteration=5");
  EXPECT_NE(set.exit_code, 0);
  EXPECT_NE(set.output.find("ransac_iterations"), std::string::npos) << set.output;
}

// ---- Correlative search (x, y, yaw by brute force): a field of identical pillars -------------

namespace {

// A 4 × 3 grid of identical pillars (radius 1 m, 3 m high, 4 m apart) on a 36 m floor: the
// layout maps onto itself by a half turn about (6, 4). `heat_shift` moves the heat patch on the
// north side of pillar (4, 0) (labels only); `drop_pillar` removes pillar (12, 8), breaking the
// symmetry in the structure itself. World frame, floor at z = 0.
LabeledCloud pillarGrid(const Eigen::Vector2d& heat_shift = Eigen::Vector2d::Zero(), bool drop_pillar = false) {
  LabeledCloud c;
  for (double x = -12.0; x <= 24.0; x += 0.25)
    for (double y = -14.0; y <= 22.0; y += 0.25) c.push_back(Eigen::Vector3f(float(x), float(y), 0.0f), 0);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) {
      if (drop_pillar && i == 3 && j == 2) continue;
      for (int a = 0; a < 64; ++a)
        for (double z = 0.1; z < 3.0; z += 0.15) {
          const double t = 2.0 * M_PI * a / 64.0;
          const Eigen::Vector2d p(4.0 * i + std::cos(t), 4.0 * j + std::sin(t));
          const bool heat = i == 1 && j == 0 && std::sin(t) > 0.5 && z > 0.5 && z < 2.0;
          const Eigen::Vector2d q = heat ? Eigen::Vector2d(p + heat_shift) : p;
          c.push_back(Eigen::Vector3f(float(q.x()), float(q.y()), float(z)), heat ? ClassId(1) : ClassId(0));
        }
    }
  return c;
}

// What a sensor 0.5 m above the floor at (x, y, yaw) sees within 14 m, in its own frame.
LabeledCloud seenFrom(const LabeledCloud& world, const Eigen::Isometry3d& pose) {
  LabeledCloud q;
  const Eigen::Isometry3d inv = pose.inverse();
  for (std::size_t i = 0; i < world.size(); ++i)
    if ((world.points[i].cast<double>() - pose.translation()).head<2>().norm() < 14.0)
      q.push_back((inv * world.points[i].cast<double>()).cast<float>(), world.classes[i]);
  return q;
}

// The places a robot driving around the field could be: its loop, every metre.
std::vector<Eigen::Vector2d> loopAroundTheField() {
  std::vector<Eigen::Vector2d> places;
  for (double t = -4.0; t <= 16.0; t += 1.0) places.push_back({t, -4.0}), places.push_back({t, 12.0});
  for (double t = -4.0; t <= 12.0; t += 1.0) places.push_back({-4.0, t}), places.push_back({16.0, t});
  return places;
}

const Eigen::Isometry3d kWestSide = Eigen::Translation3d(-4.0, 1.0, 0.5) * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ());

}  // namespace

// Identical pillars: every place along the loop has a twin by the half turn. The heat patch,
// seen from the west side, tells the two apart.
TEST(CorrelativeSearch, LabelsPickThePlaceAmongIdenticalPillars) {
  const ClassTable classes = ClassTable::defaults();
  const CorrelativeTarget target(pillarGrid(), 0.5, classes);
  const CorrelativeResult r = searchCorrelative(seenFrom(pillarGrid(), kWestSide), target, loopAroundTheField(), 3.0, classes);
  std::printf("pillars: %s; error %.3f m / %.2f deg\n", r.reason.c_str(), transErr(r.transform, kWestSide),
              rotErrDeg(r.transform, kWestSide));
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_NE(r.reason.find("the labels chose one"), std::string::npos) << r.reason;
  EXPECT_LT(transErr(r.transform, kWestSide), 0.15);
  EXPECT_LT(rotErrDeg(r.transform, kWestSide), 1.5);
}

// Without labels the twin cannot be told apart, and the search says so instead of guessing.
TEST(CorrelativeSearch, TheTwinWithoutLabelsIsRefused) {
  const ClassTable classes = ClassTable::defaults();
  const CorrelativeTarget target(pillarGrid(), 0.5, classes);
  LabeledCloud query = seenFrom(pillarGrid(), kWestSide);
  std::fill(query.classes.begin(), query.classes.end(), ClassId(0));
  const CorrelativeResult r = searchCorrelative(query, target, loopAroundTheField(), 3.0, classes);
  std::printf("pillars, no labels: %s\n", r.reason.c_str());
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.reason.find("ambiguous"), std::string::npos) << r.reason;
}

// A hazard that moved since (the patch 2 m along the pillar row) never drags the answer: in the
// symmetric field it supports neither twin and the search refuses; where the structure alone
// decides (one pillar gone), the answer is the structure's, not 2 m off with the patch.
TEST(CorrelativeSearch, AMovedHazardNeverOutvotesTheStructure) {
  const ClassTable classes = ClassTable::defaults();
  const Eigen::Vector2d moved(2.0, 0.0);
  const CorrelativeTarget symmetric(pillarGrid(), 0.5, classes);
  const CorrelativeResult twin = searchCorrelative(seenFrom(pillarGrid(moved), kWestSide), symmetric,
                                                   loopAroundTheField(), 3.0, classes);
  EXPECT_FALSE(twin.success) << twin.reason;
  const CorrelativeTarget broken(pillarGrid({0, 0}, true), 0.5, classes);
  const Eigen::Isometry3d east = Eigen::Translation3d(16.0, 6.0, 0.5) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ());
  const CorrelativeResult r = searchCorrelative(seenFrom(pillarGrid(moved, true), east), broken, loopAroundTheField(), 3.0, classes);
  std::printf("one pillar gone, patch moved: %s; error %.3f m\n", r.reason.c_str(), transErr(r.transform, east));
  ASSERT_TRUE(r.success) << r.reason;
  EXPECT_LT(transErr(r.transform, east), 0.15);
}

TEST(CorrelativeSearch, TooLittleStructureOrNoTargetSaySo) {
  const ClassTable classes = ClassTable::defaults();
  const CorrelativeTarget target(pillarGrid(), 0.5, classes);
  LabeledCloud floor_only;
  for (double x = -5; x < 5; x += 0.2)
    for (double y = -5; y < 5; y += 0.2) floor_only.push_back(Eigen::Vector3f(float(x), float(y), -0.5f), 0);
  const CorrelativeResult r = searchCorrelative(floor_only, target, loopAroundTheField(), 3.0, classes);
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.reason.find("structure points above the floor"), std::string::npos) << r.reason;
  const CorrelativeTarget none(floor_only, 0.0, classes);
  EXPECT_TRUE(none.empty());
  const CorrelativeResult n = searchCorrelative(seenFrom(pillarGrid(), kWestSide), none, loopAroundTheField(), 3.0, classes);
  EXPECT_FALSE(n.success);
  EXPECT_NE(n.reason.find("no structure"), std::string::npos) << n.reason;
  EXPECT_FALSE(searchCorrelative(LabeledCloud{}, target, loopAroundTheField(), 3.0, classes).success);
  EXPECT_FALSE(searchCorrelative(seenFrom(pillarGrid(), kWestSide), target, {}, 3.0, classes).success);
}
