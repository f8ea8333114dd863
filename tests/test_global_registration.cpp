// Global registration (issue 19) on real scans — KITTI, the scan pair, the VLP-16 and Ouster
// recordings — and on the simulated naraha scans with property classes: known jumps (yaw up to
// 180°, metres of translation) recovered without an initial guess; bad input and ambiguity.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <random>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "test_helpers.hpp"
#include "test_registration_scenes.hpp"

using namespace hazmap;

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Isometry3d readMatrix4(const std::filesystem::path& path) {
  std::ifstream in(path);
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) in >> m(r, c);
  EXPECT_TRUE(in) << path;
  Eigen::Isometry3d T;
  T.matrix() = m;
  return T;
}

double transErr(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return (a.inverse() * b).translation().norm(); }
double rotErrDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) { return rotationAngle(a.inverse() * b) / kDeg; }

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
  const Eigen::Isometry3d reference = readMatrix4(dir / "relative.txt");
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
