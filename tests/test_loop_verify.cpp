// Loop verification by property-aware ICP on synthetic keyframe pairs, and the LoopDetector end
// to end (landmarks → candidates → ICP → gates) on a synthetic route with drift.
#include <gtest/gtest.h>
#include <algorithm>

#include "hazmap/core/error.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "test_helpers.hpp"
#include "test_loop_scene.hpp"

using namespace hazmap;

namespace {

// A hall (24 m × 16 m, 4 m walls) with a few asymmetric boxes, sampled every `step`, plus the
// property patches of test::routePatches() (shifted into the hall).
LabeledCloud hallWorld(double step = 0.12) {
  LabeledCloud w;
  w.enableProperty();
  auto plane = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v) {
    const int nu = static_cast<int>(u.norm() / step), nv = static_cast<int>(v.norm() / step);
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j)
        w.push_back((o + u * (double(i) / nu) + v * (double(j) / nv)).cast<float>(), 0, 0, 0, 20.f);
  };
  const double x0 = -4, y0 = -5, X = 24, Y = 16, H = 4;
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(), ey = Eigen::Vector3d::UnitY(), ez = Eigen::Vector3d::UnitZ();
  plane({x0, y0, 0}, X * ex, Y * ey);          // floor
  plane({x0, y0, 0}, X * ex, H * ez);          // walls
  plane({x0, y0 + Y, 0}, X * ex, H * ez);
  plane({x0, y0, 0}, Y * ey, H * ez);
  plane({x0 + X, y0, 0}, Y * ey, H * ez);
  auto box = [&](double x, double y, double sx, double sy, double h) {
    plane({x, y, 0}, sx * ex, h * ez);
    plane({x, y + sy, 0}, sx * ex, h * ez);
    plane({x, y, 0}, sy * ey, h * ez);
    plane({x + sx, y, 0}, sy * ey, h * ez);
    plane({x, y, h}, sx * ex, sy * ey);
  };
  box(5.0, 5.0, 1.0, 2.5, 1.5);
  box(14.0, -3.0, 2.0, 1.0, 2.5);
  box(-1.0, 8.0, 1.5, 1.5, 1.0);
  box(9.0, 9.0, 3.0, 0.8, 2.0);
  w.append(test::samplePatches(test::routePatches(), step));
  return w;
}

// What LoopDetector stores for verification: the keyframe voxel-downsampled, property points
// winning their voxel.
LabeledCloud keyframeCloud(const LabeledCloud& c) {
  return voxelDownsample(c, propertyVoxels(LoopClosureConfig{}.keyframe_voxel), ClassTable::defaults());
}

// Two keyframes of the hall 1.8 m and 0.7 rad apart and the loop candidate between them, its guess
// 0.5 m / 0.05 rad off the truth (the verification tests' standard true loop).
struct HallLoop {
  LabeledCloud match, query;
  LoopCandidate cand;
  Eigen::Isometry3d truth;  ///< match ← query
};
HallLoop hallLoop(const LabeledCloud& world, std::mt19937& rng) {
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, 0.5, 0.5, 0, 0, 0.3);
  const Eigen::Isometry3d Tb = fromXyzRpy(2.5, -0.5, 0.5, 0, 0, 1.0);
  HallLoop h;
  h.match = keyframeCloud(test::observe(world, Ta, 15.0, 0.02, 0.5, rng));
  h.query = keyframeCloud(test::observe(world, Tb, 15.0, 0.02, 0.5, rng));
  h.cand.query = 30;
  h.cand.match = 2;
  h.truth = Ta.inverse() * Tb;
  h.cand.initial_guess = h.truth * fromXyYaw(0.4, -0.3, 0.05);
  return h;
}

TEST(LoopVerify, PropertyIcpRefinesAConstellationGuessAndGivesInformation) {
  const LabeledCloud world = hallWorld();
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(5);
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, 0.5, 0.5, 0, 0, 0.3);
  const Eigen::Isometry3d Tb = fromXyzRpy(2.5, -0.5, 0.5, 0, 0, 1.0);
  const LabeledCloud a = test::observe(world, Ta, 15.0, 0.02, 0.5, rng);
  const LabeledCloud b = test::observe(world, Tb, 15.0, 0.02, 0.5, rng);
  const auto la = extractLandmarks(a, table), lb = extractLandmarks(b, table);
  const auto m = matchConstellations(lb, la);
  ASSERT_TRUE(m.has_value());
  LoopCandidate cand;
  cand.query = 30;
  cand.match = 2;
  cand.initial_guess = m->T_match_query;
  const VerificationResult v = verifyCandidate(cand, keyframeCloud(b), keyframeCloud(a), table, {});
  ASSERT_TRUE(v.accepted) << v.reason;
  const Eigen::Isometry3d truth = Ta.inverse() * Tb;
  const Eigen::Isometry3d err = truth.inverse() * v.closure.T_from_to;
  EXPECT_LT(translationNorm(err), 0.05);
  EXPECT_LT(rotationAngle(err), 0.005);
  // Verification improved on the landmark guess.
  EXPECT_LE(translationNorm(err), translationNorm(truth.inverse() * cand.initial_guess) + 1e-9);
  EXPECT_EQ(v.closure.from, 2u);
  EXPECT_EQ(v.closure.to, 30u);
  EXPECT_TRUE((v.closure.information * v.closure.covariance).isApprox(Matrix6d::Identity(), 1e-6));
  EXPECT_GT(v.closure.information.diagonal().minCoeff(), 0.0);
}

// Issue 14's online cost: the full run refining the coarse check's answer, the probes' coarse
// stage and looser stop accept the same loop, within millimetres of the single-stage verification.
TEST(LoopVerify, CheaperVerificationAcceptsTheSameLoop) {
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(5);
  const auto [a, b, cand, truth] = hallLoop(hallWorld(), rng);
  VerificationConfig single;  // single stage throughout (the defaults before 2026-12-02)
  single.probe_coarse_points = 0;
  single.probe_tolerance_scale = 1.0;
  VerificationConfig cheap;
  cheap.full_from_coarse_within = 2.0;
  cheap.probe_coarse_points = 1000;
  cheap.probe_tolerance_scale = 10.0;
  const VerificationResult v1 = verifyCandidate(cand, b, a, table, single);
  const VerificationResult v2 = verifyCandidate(cand, b, a, table, cheap);
  ASSERT_TRUE(v1.accepted) << v1.reason;
  ASSERT_TRUE(v2.accepted) << v2.reason;
  const Eigen::Isometry3d d = v1.closure.T_from_to.inverse() * v2.closure.T_from_to;
  EXPECT_LT(translationNorm(d), 0.003);
  EXPECT_LT(rotationAngle(d), 0.0005);
  // The probes' spread joins both covariances alike (within the floors' scale).
  EXPECT_LT((v1.closure.covariance - v2.closure.covariance).norm(), 1e-4);
}

// full_from_coarse_within: a coarse answer near the guess is refined, not recomputed (fewer full
// searches, the same loop); one that moved farther than the radius leaves the full run at the guess.
TEST(LoopVerify, FullRunRefinesOnlyACoarseAnswerNearTheGuess) {
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(5);
  const auto [a, b, cand, truth] = hallLoop(hallWorld(), rng);
  VerificationConfig from_guess;
  from_guess.probe_distance = 0.0;  // the full run alone
  VerificationConfig refine = from_guess;
  refine.full_from_coarse_within = 2.0;  // the guess is 0.5 m and 0.05 rad off: 1.0 in its measure
  const VerificationResult v0 = verifyCandidate(cand, b, a, table, from_guess);
  const VerificationResult v1 = verifyCandidate(cand, b, a, table, refine);
  ASSERT_TRUE(v0.accepted) << v0.reason;
  ASSERT_TRUE(v1.accepted) << v1.reason;
  EXPECT_LT(v1.registration.iterations, v0.registration.iterations);
  const Eigen::Isometry3d d = v0.closure.T_from_to.inverse() * v1.closure.T_from_to;
  EXPECT_LT(translationNorm(d), 0.002);
  EXPECT_LT(rotationAngle(d), 0.0003);
  // Below that move the full run starts at the guess: the same run bit for bit.
  VerificationConfig tight = from_guess;
  tight.full_from_coarse_within = 0.5;
  const VerificationResult v2 = verifyCandidate(cand, b, a, table, tight);
  EXPECT_EQ(v2.registration.iterations, v0.registration.iterations);
  EXPECT_TRUE(v2.closure.T_from_to.isApprox(v0.closure.T_from_to, 0.0));
}

TEST(LoopVerify, RejectsAWrongCandidate) {
  const LabeledCloud world = hallWorld();
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(6);
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, 0.5, 0.5, 0, 0, 0.3);
  const Eigen::Isometry3d Tb = fromXyzRpy(2.5, -0.5, 0.5, 0, 0, 1.0);
  const LabeledCloud a = test::observe(world, Ta, 15.0, 0.02, 0.5, rng);
  const LabeledCloud b = test::observe(world, Tb, 15.0, 0.02, 0.5, rng);
  LoopCandidate cand;
  cand.query = 30;
  cand.match = 2;
  // A wrong hypothesis: 4 m and 90° off the truth.
  cand.initial_guess = (Ta.inverse() * Tb) * fromXyYaw(4.0, 1.0, M_PI / 2);
  const VerificationResult v = verifyCandidate(cand, keyframeCloud(b), keyframeCloud(a), table, {});
  EXPECT_FALSE(v.accepted);
  EXPECT_FALSE(v.reason.empty());
  // Empty keyframes are rejected, not crashed on.
  EXPECT_FALSE(verifyCandidate(cand, LabeledCloud{}, a, table, {}).accepted);
}

// Issue 14's online cost: the overlap check at the guess (guess_check_points) rejects a candidate
// whose scans barely overlap where the guess puts them, without the coarse ICP, and leaves a true
// loop's verification exactly as it was.
TEST(LoopVerify, GuessCheckRejectsOnlyHopelessCandidates) {
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(7);
  auto [a, b, cand, truth] = hallLoop(hallWorld(), rng);
  VerificationConfig off;
  off.guess_check_points = 0;
  VerificationConfig on;
  on.guess_check_points = 300;
  const VerificationResult v_off = verifyCandidate(cand, b, a, table, off);
  const VerificationResult v_on = verifyCandidate(cand, b, a, table, on);
  ASSERT_TRUE(v_off.accepted) << v_off.reason;
  ASSERT_TRUE(v_on.accepted) << v_on.reason;
  EXPECT_TRUE(v_on.closure.T_from_to.matrix() == v_off.closure.T_from_to.matrix());
  EXPECT_TRUE(v_on.closure.covariance == v_off.closure.covariance);
  // The guess puts the query scan 12 m along and 2.5 m up, turned half round: little overlap.
  cand.initial_guess = truth * fromXyzRpy(12.0, 3.0, 2.5, 0, 0, M_PI);
  const VerificationResult hopeless = verifyCandidate(cand, b, a, table, on);
  EXPECT_FALSE(hopeless.accepted);
  EXPECT_EQ(hopeless.rejection, LoopRejection::LowFitness);
  EXPECT_NE(hopeless.reason.find("overlap at the guess"), std::string::npos) << hopeless.reason;
  // Without the check the same candidate still fails, later (the coarse check or the full run).
  EXPECT_FALSE(verifyCandidate(cand, b, a, table, off).accepted);
}

TEST(LoopVerify, DetectorClosesTheRouteLoopUnderDrift) {
  const LabeledCloud world = hallWorld(0.2);
  const ClassTable table = ClassTable::defaults();
  const PoseList truth = test::rectangleRoute();
  // Heavy drift (6 % scale, 0.5°/m yaw): the estimate is metres off at the revisit.
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  std::mt19937 rng(9);
  LoopClosureConfig cfg;
  cfg.method = CandidateMethod::Constellation;
  LoopDetector det(table, cfg);
  std::size_t with_candidates = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    det.addKeyframe(test::observe(world, truth[i], 12.0, 0.02, 0.6, rng));
    // Verify only on the last side of the route (the revisit) to keep the test fast.
    if (i + 6 < truth.size()) continue;
    const LoopDetection d = det.detect(i, estimate);
    with_candidates += !d.candidates.empty();
  }
  EXPECT_GE(with_candidates, 4u);
  const auto& accepted = det.acceptedLoops();
  ASSERT_GE(accepted.size(), 3u);
  for (const auto& l : accepted) EXPECT_TRUE(isTrueLoop(l, truth, 0.1, 0.01)) << l.from << "→" << l.to;
  const auto consistent = det.consistentLoops(estimate);
  EXPECT_EQ(consistent.size(), accepted.size());
  // The distance baseline on the same drifted estimate closes no true loop.
  LoopClosureConfig dcfg = cfg;
  dcfg.method = CandidateMethod::Distance;
  LoopDetector dist(table, dcfg);
  for (std::size_t i = 0; i < truth.size(); ++i) {
    dist.addKeyframe(*det.cloud(i));
    if (i + 6 < truth.size()) continue;
    dist.detect(i, estimate);
  }
  for (const auto& l : dist.acceptedLoops()) EXPECT_FALSE(isTrueLoop(l, truth));

  // Bounded memory: with a loader and 3 resident keyframes, old clouds are dropped and reloaded
  // when a candidate needs them, and the loops found are exactly the same.
  std::vector<LabeledCloud> raw;
  std::mt19937 rng2(9);
  for (std::size_t i = 0; i < truth.size(); ++i) raw.push_back(test::observe(world, truth[i], 12.0, 0.02, 0.6, rng2));
  LoopClosureConfig bcfg = cfg;
  bcfg.resident_keyframes = 3;
  LoopDetector bounded(table, bcfg);
  std::size_t loads = 0;
  bounded.setCloudLoader([&](std::size_t k) {
    ++loads;
    return raw.at(k);
  });
  for (std::size_t i = 0; i < truth.size(); ++i) {
    bounded.addKeyframe(raw[i]);
    EXPECT_LE(bounded.residentClouds(), 3u);
    if (i + 6 < truth.size()) continue;
    bounded.detect(i, estimate);
  }
  EXPECT_GT(loads, 0u);
  ASSERT_EQ(bounded.acceptedLoops().size(), accepted.size());
  for (std::size_t k = 0; k < accepted.size(); ++k) {
    EXPECT_EQ(bounded.acceptedLoops()[k].from, accepted[k].from);
    EXPECT_TRUE(bounded.acceptedLoops()[k].T_from_to.isApprox(accepted[k].T_from_to, 1e-9));
  }
}

}  // namespace

namespace {

// Online cost (loop_closure.submap_reuse_tolerance): a cached verification target is reused while
// its keyframes sit within the tolerance of where it placed them (an optimisation moved them by a
// millimetre), and rebuilt once one moved farther; with 0 every change of placement rebuilds it.
TEST(LoopVerify, SubmapTargetReusedWithinTheTolerance) {
  const LabeledCloud world = keyframeCloud(hallWorld(0.4));
  PoseList estimate;
  for (int i = 0; i < 8; ++i) estimate.push_back(fromXyYaw(1.0 * i, 0.0, 0.0));
  PoseList nudged = estimate, moved = estimate;
  nudged[5].translation().x() += 0.001;  // 1 mm: within 5 mm
  moved[5].translation().x() += 0.05;    // 5 cm: beyond
  const auto targets = [&](double tolerance) {
    LoopClosureConfig cfg;
    cfg.submap_reuse_tolerance = tolerance;
    LoopDetector det(ClassTable::defaults(), cfg);
    for (int i = 0; i < 8; ++i) det.addKeyframe(world);
    const auto a = det.submapTarget(3, 30, estimate);
    const auto b = det.submapTarget(3, 30, nudged);
    const auto c = det.submapTarget(3, 30, moved);
    return std::make_tuple(a == b, b == c, det.submapTargetsBuilt());
  };
  EXPECT_EQ(targets(0.005), std::make_tuple(true, false, std::size_t{2}));
  EXPECT_EQ(targets(0.0), std::make_tuple(false, false, std::size_t{3}));
}

}  // namespace

namespace {

// Online cost (loop_closure.light_duplicate_keyframes): along the revisit each keyframe closes its
// own loop to the same old place. With the rule on, a candidate within 2 keyframes of a fully
// checked loop is verified by the same ICP and basin probes but, agreeing with that loop, takes
// over its reverse cross-check's verdict. Every loop is still found, each at the very same pose;
// only some are light, and those never serve as the reference.
TEST(LoopVerify, LightDuplicatesKeepEveryLoopAtTheSamePose) {
  const LabeledCloud world = hallWorld(0.2);
  const ClassTable table = ClassTable::defaults();
  const PoseList truth = test::rectangleRoute();
  const PoseList estimate = test::driftedRoute(truth, 0.02, 0.1 * M_PI / 180.0);
  std::mt19937 rng(9);
  std::vector<LabeledCloud> raw;
  for (std::size_t i = 0; i < truth.size(); ++i) raw.push_back(test::observe(world, truth[i], 12.0, 0.02, 0.6, rng));
  const auto run = [&](std::size_t window, std::size_t& light) {
    LoopClosureConfig cfg;
    cfg.method = CandidateMethod::Constellation;
    cfg.light_duplicate_keyframes = window;
    LoopDetector det(table, cfg);
    light = 0;
    for (std::size_t i = 0; i < truth.size(); ++i) {
      det.addKeyframe(raw[i]);
      if (i + 6 < truth.size()) continue;
      light += det.detect(i, estimate).light_verifications;
    }
    return det.acceptedLoops();
  };
  std::size_t light_off = 0, light_on = 0;
  const std::vector<LoopClosure> full = run(0, light_off);
  const std::vector<LoopClosure> light = run(2, light_on);
  ASSERT_GE(full.size(), 3u);
  EXPECT_EQ(light_off, 0u);
  EXPECT_GT(light_on, 0u);
  EXPECT_LT(light_on, light.size());  // the first loop to a place is always fully checked
  ASSERT_EQ(light.size(), full.size());
  for (std::size_t a = 0; a < full.size(); ++a) {
    EXPECT_EQ(light[a].from, full[a].from);
    EXPECT_EQ(light[a].to, full[a].to);
    EXPECT_EQ(light[a].T_from_to.matrix(), full[a].T_from_to.matrix());
    EXPECT_TRUE(isTrueLoop(light[a], truth, 0.1, 0.01)) << light[a].from << "→" << light[a].to;
  }
}

}  // namespace
