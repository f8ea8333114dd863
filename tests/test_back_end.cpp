// Issue 14's back end: the calibrated χ² gate, submap construction, the graph's chain
// covariance, the failure paths (a loop the solution rejects, a graph Ceres cannot solve), the
// records in run.json, and the rule that loops and PGO never make the map worse.
#include <algorithm>
#include <array>
#include <cstring>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/graph/chain_covariance.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/loop/consistency.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/loop/verification.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

Eigen::Isometry3d pose(double x, double y, double yaw) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, 0);
  return T;
}

Matrix6d isotropic(double st, double sr) {
  return (Vector6d() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr).finished().asDiagonal();
}

// Keyframes 0..n-1 of one point each, (1, k, 0) in the keyframe's frame, placed 2 m apart along x.
PoseList addPointKeyframes(LoopDetector& det, int n) {
  PoseList est;
  for (int k = 0; k < n; ++k) {
    LabeledCloud cloud;
    cloud.push_back(Eigen::Vector3f(1.0f, static_cast<float>(k), 0.0f), 0);
    det.addKeyframe(cloud);
    est.push_back(pose(2.0 * k, 0, 0));
  }
  return est;
}

bool hasPoint(const LabeledCloud& cloud, const Eigen::Vector3f& e) {
  return std::any_of(cloud.points.begin(), cloud.points.end(), [&](const Eigen::Vector3f& p) { return (p - e).norm() < 1e-5f; });
}

}  // namespace

TEST(ChainCovariance, StraightChainAddsUpAndRotatesIntoTheStartFrame) {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<Matrix6d> steps;
  for (int k = 0; k < 5; ++k) {
    poses.push_back(pose(k, 0, 0));
    steps.push_back(k == 0 ? Matrix6d::Zero() : isotropic(0.01, 0.001));
  }
  // Pure translation noise adds up; rotation noise at node k moves node 4 by (4 − k) m sideways.
  const Matrix6d s = chainCovariance(poses, steps, 0, 4);
  EXPECT_NEAR(s(0, 0), 4 * 1e-4, 1e-12);
  EXPECT_NEAR(s(1, 1), 4 * 1e-4 + 1e-6 * (0 + 1 + 4 + 9), 1e-12);  // levers 0, 1, 2, 3 m
  EXPECT_NEAR(s(5, 5), 4 * 1e-6, 1e-15);
  // Reversed: the same uncertainty moved to the other end (T_40 = T_04⁻¹, Ad(T_40) Σ Ad(T_40)ᵀ).
  const Matrix6d r = chainCovariance(poses, steps, 4, 0);
  const Matrix6d Ad = adjoint(poses[4].inverse() * poses[0]);
  EXPECT_TRUE(r.isApprox(Ad * s * Ad.transpose(), 1e-12));
  EXPECT_NEAR(r(5, 5), s(5, 5), 1e-15);
  EXPECT_THROW(chainCovariance(poses, steps, 0, 5), Error);
}

// The map anchors keep only their non-zero steps (issue 33): the sparse sum is the dense one bit
// for bit, both ways round and over spans that start or end on a zero step.
TEST(ChainCovariance, SparseStepsGiveTheDenseSumBitForBit) {
  std::vector<Eigen::Isometry3d> poses{pose(0, 0, 0)};
  std::vector<Matrix6d> dense{Matrix6d::Zero()};
  SparseSteps sparse;
  for (int k = 1; k < 12; ++k) {
    poses.push_back(poses.back() * pose(0.7, 0.1 * k, 0.05 * k));
    dense.push_back(k % 3 == 1 ? isotropic(0.01 * k, 0.002 * k) : Matrix6d::Zero());
    if (k % 3 == 1) sparse.emplace_back(k, dense.back());
  }
  for (std::size_t from = 0; from < poses.size(); ++from)
    for (std::size_t to = 0; to < poses.size(); ++to) {
      const Matrix6d a = chainCovariance(poses, dense, from, to), b = chainCovariance(poses, sparse, from, to);
      EXPECT_EQ(0, std::memcmp(a.data(), b.data(), sizeof(double) * 36)) << from << " -> " << to;
    }
  EXPECT_TRUE(chainCovariance(poses, sparse, 0, 11).isApprox(chainCovariance(poses, dense, 0, 11)));
  EXPECT_FALSE(chainCovariance(poses, sparse, 0, 11).isZero());
  EXPECT_THROW(chainCovariance(poses, sparse, 0, 12), Error);
}

TEST(ChainCovariance, MatchesMonteCarlo) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<Eigen::Isometry3d> poses{pose(0, 0, 0)};
  std::vector<Matrix6d> steps{Matrix6d::Zero()};
  for (int k = 1; k < 8; ++k) {
    poses.push_back(poses.back() * pose(1.0, 0.2, 0.3));
    steps.push_back(isotropic(0.02, 0.01));
  }
  const Matrix6d predicted = chainCovariance(poses, steps, 0, 7);
  Matrix6d sample = Matrix6d::Zero();
  const int N = 20000;
  const Eigen::Isometry3d truth = poses[0].inverse() * poses[7];
  for (int s = 0; s < N; ++s) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int k = 1; k < 8; ++k) {
      Vector6d xi;
      for (int i = 0; i < 6; ++i) xi(i) = n(rng) * std::sqrt(steps[k](i, i));
      T = T * (se3Exp(xi) * (poses[k - 1].inverse() * poses[k]));
    }
    const Vector6d e = se3Log(T * truth.inverse());
    sample += e * e.transpose() / N;
  }
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(sample(i, i), predicted(i, i), 0.08 * predicted(i, i)) << i;
}

TEST(InnovationGate, AcceptsWithinTheCombinedUncertaintyAndRejectsBeyond) {
  const PoseList est{pose(0, 0, 0), pose(10, 0, 0)};
  LoopClosure loop;
  loop.from = 0;
  loop.to = 1;
  loop.covariance = isotropic(0.02, 0.002);
  const Matrix6d rel = isotropic(0.03, 0.003);
  // 5 cm off along x: d² = 0.05² / (0.02² + 0.03²) = 1.92 < χ²₆(0.999) = 22.46.
  loop.T_from_to = pose(10.05, 0, 0);
  GateResult g = innovationGate(loop, est, rel, 0.999);
  EXPECT_TRUE(g.accepted);
  EXPECT_NEAR(g.mahalanobis2, 0.0025 / 0.0013, 1e-6);
  EXPECT_NEAR(g.threshold, 22.458, 1e-3);
  // 25 cm off: d² = 48 > 22.46.
  loop.T_from_to = pose(10.25, 0, 0);
  g = innovationGate(loop, est, rel, 0.999);
  EXPECT_FALSE(g.accepted);
  // The same error passes when the graph says the relative pose is that uncertain.
  EXPECT_TRUE(innovationGate(loop, est, isotropic(0.2, 0.02), 0.999).accepted);
  // Out-of-range keyframes and a non-finite covariance are errors.
  loop.to = 2;
  EXPECT_THROW(innovationGate(loop, est, rel, 0.999), Error);
  loop.to = 1;
  Matrix6d bad = rel;
  bad(0, 0) = std::nan("");
  EXPECT_THROW(innovationGate(loop, est, bad, 0.999), Error);
}

TEST(LoopSubmap, PlacesNeighbourKeyframesWithTheEstimateInTheMatchFrame) {
  ClassTable classes = ClassTable::defaults();
  LoopClosureConfig c;
  c.keyframe_voxel = 0.0;  // keep every point, so the test sees the placement exactly
  c.submap_keyframes = 1;
  c.candidates.min_index_gap = 2;
  LoopDetector det(classes, c);
  const PoseList est = addPointKeyframes(det, 6);
  // Keyframe 2 with neighbours 1 and 3 (a query at 5 allows up to 5 − 2 = 3).
  LabeledCloud s = det.submap(2, 5, est);
  ASSERT_EQ(s.size(), 3u);
  std::vector<Eigen::Vector3f> expected{{1, 2, 0}, {-1, 1, 0}, {3, 3, 0}};  // own, k=1 at −2 m, k=3 at +2 m
  for (const auto& e : expected) EXPECT_TRUE(hasPoint(s, e)) << e.transpose();
  // A query too close in index keeps the newer neighbour out.
  EXPECT_EQ(det.submap(2, 4, est).size(), 2u);
  // Off: the keyframe's own cloud.
  c.submap_keyframes = 0;
  LoopDetector single(classes, c);
  for (int k = 0; k < 3; ++k) single.addKeyframe(det.cloud(k)->slice(0, 1));
  EXPECT_EQ(single.submap(1, 2, est).size(), 1u);
  EXPECT_THROW(det.submap(9, 5, est), Error);
  EXPECT_THROW(det.submap(2, 5, PoseList(est.begin(), est.begin() + 3)), Error);
}

TEST(LoopSubmap, TheQuerySubmapPlacesTheKeyframesBeforeTheQueryInItsFrame) {
  ClassTable classes = ClassTable::defaults();
  LoopClosureConfig c;
  c.keyframe_voxel = 0.0;
  c.cross_check_query_keyframes = 2;
  LoopDetector det(classes, c);
  const PoseList est = addPointKeyframes(det, 5);
  // Keyframe 4 with the two before it (3 at −2 m, 2 at −4 m); keyframe 5 does not exist.
  const LabeledCloud s = det.querySubmap(4, est);
  ASSERT_EQ(s.size(), 3u);
  for (const Eigen::Vector3f e : {Eigen::Vector3f(1, 4, 0), Eigen::Vector3f(-1, 3, 0), Eigen::Vector3f(-3, 2, 0)})
    EXPECT_TRUE(hasPoint(s, e)) << e.transpose();
  EXPECT_EQ(det.querySubmap(1, est).size(), 2u);  // only keyframe 0 before it
  EXPECT_THROW(det.querySubmap(5, est), Error);
  EXPECT_THROW(det.querySubmap(4, PoseList(est.begin(), est.begin() + 3)), Error);
}

// The reverse cross-check, submap against submap: a right loop agrees with it, one 5 cm / 8 mrad
// off (naraha's wrong long-baseline loops: height and pitch) does not. The query keyframe's own
// scan sees only the floor, so registering onto it alone cannot check the loop; its neighbourhood can.
namespace {

LabeledCloud corridorWorld() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  LabeledCloud w;
  for (int i = 0; i < 40000; ++i) {
    const float x = -6.0f + 30.0f * u(rng), y = -4.0f + 8.0f * u(rng), z = 3.0f * u(rng);
    w.push_back(Eigen::Vector3f(x, y, 0.0f), 0);                     // floor
    w.push_back(Eigen::Vector3f(x, i % 2 ? -4.0f : 4.0f, z), 0);     // walls
  }
  for (int b = 0; b < 12; ++b)  // pillars along the walls fix the corridor's axis
    for (int i = 0; i < 600; ++i) {
      const float a = 6.2832f * u(rng);
      const float y = b % 2 ? -3.4f : 3.4f;
      w.push_back(Eigen::Vector3f(-4.0f + 2.3f * b + 0.3f * std::cos(a), y + 0.3f * std::sin(a), 3.0f * u(rng)), 0);
    }
  return w;
}

LabeledCloud scanAt(const LabeledCloud& world, const Eigen::Isometry3d& T_world_sensor, bool floor_only) {
  LabeledCloud scan;
  const Eigen::Isometry3f T = T_world_sensor.inverse().cast<float>();
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector3f p = T * world.points[i];
    if (p.head<2>().norm() > 10.0f || (floor_only && std::abs(world.points[i].z()) > 1e-6f)) continue;
    scan.push_back(p, world.classes[i]);
  }
  return scan;
}

}  // namespace

TEST(LoopCrossCheck, TheQuerysNeighbourhoodTellsARightLoopFromOneOffInHeightAndPitch) {
  const LabeledCloud world = corridorWorld();
  ClassTable classes = ClassTable::defaults();
  LoopClosureConfig c;
  c.verification.tracking_registration.use_classes = false;
  // Keyframes 0–5 at x = 0…5, 6–16 far away (nothing there), 17–23 at x = 4…10: the same corridor again.
  PoseList truth;
  for (int k = 0; k < 24; ++k) truth.push_back(k < 6 ? pose(k, 0, 0) : k < 17 ? pose(200.0 + k, 0, 0) : pose(k - 13.0, 0, 0));
  auto make = [&](std::size_t query_keyframes) {
    c.cross_check_query_keyframes = query_keyframes;
    auto det = std::make_unique<LoopDetector>(classes, c);
    for (int k = 0; k < 24; ++k) det->addKeyframe(scanAt(world, truth[k], k == 23));
    return det;
  };
  LoopCandidate cand;
  cand.match = 3;
  cand.query = 23;
  const Eigen::Isometry3d right = truth[3].inverse() * truth[23];  // 7 m apart
  cand.initial_guess = pose(0.1, -0.05, 0.01) * right;
  Vector6d off;
  off << 0.0, 0.0, 0.05, 0.0, 0.008, 0.0;
  const Eigen::Isometry3d wrong = se3Exp(off) * right;
  const Matrix6d forward = isotropic(0.005, 0.0005);
  const auto submaps = make(6);
  EXPECT_LT(submaps->crossCheckDistance(cand, truth, right, forward), 1.0);
  EXPECT_GT(submaps->crossCheckDistance(cand, truth, wrong, forward), 10.0);
  // The floor-only scan alone leaves x, y and yaw to the guess: the right loop fails the check.
  const double single = make(0)->crossCheckDistance(cand, truth, right, forward);
  EXPECT_FALSE(single <= c.verification.cross_check_chi2) << single;
}

TEST(GuardedOptimisation, AGraphThatCannotBeSolvedKeepsThePreviousEstimate) {
  PoseGraph g;
  g.addNode(pose(0, 0, 0));
  g.addNode(pose(1, 0, 0));
  g.addNode(pose(5, 0, 0));  // not connected to the fixed node
  g.addEdge(0, 1, pose(1.1, 0, 0), Matrix6d::Identity());
  const auto before = g.poses;
  std::string failure;
  optimizePoseGraphOrKeep(g, PoseGraphConfig{}, failure);
  EXPECT_NE(failure.find("not connected"), std::string::npos) << failure;
  for (std::size_t i = 0; i < g.poses.size(); ++i) EXPECT_TRUE(g.poses[i].isApprox(before[i]));
  // Connected, it solves and moves node 1 onto its edge.
  g.addEdge(1, 2, pose(4, 0, 0), Matrix6d::Identity());
  optimizePoseGraphOrKeep(g, PoseGraphConfig{}, failure);
  EXPECT_TRUE(failure.empty()) << failure;
  EXPECT_NEAR(g.poses[1].translation().x(), 1.1, 1e-6);
}

TEST(GuardedOptimisation, AWrongLoopAgainstStiffOdometryStaysBeyondTheGate) {
  PoseGraph g;
  for (int k = 0; k < 6; ++k) g.addNode(pose(k, 0, 0));
  const Matrix6d stiff = isotropic(0.005, 0.0005).inverse();
  for (int k = 0; k < 5; ++k) g.addEdge(k, k + 1, pose(1, 0, 0), stiff);
  g.addEdge(0, 5, pose(5.05, 0, 0), isotropic(0.02, 0.002).inverse(), EdgeKind::Loop);  // agrees
  std::string failure;
  optimizePoseGraphOrKeep(g, PoseGraphConfig{}, failure);
  const double gate = chiSquareQuantile(6, 0.999);
  EXPECT_TRUE(edgesBeyond(g, EdgeKind::Loop, gate).empty());
  g.addEdge(0, 5, pose(6.0, 0.0, 0), isotropic(0.02, 0.002).inverse(), EdgeKind::Loop);  // 1 m off
  optimizePoseGraphOrKeep(g, PoseGraphConfig{}, failure);
  const auto beyond = edgesBeyond(g, EdgeKind::Loop, gate);
  ASSERT_EQ(beyond.size(), 1u);
  EXPECT_EQ(beyond[0], g.edges.size() - 1);
}

// Honest loop covariance (VerificationConfig::misfit_scale, label_only_sigma): the whole misfit
// along the Hessian's weak axis, and no information along a direction only labels constrain.
namespace {

RegistrationResult loopRegistration() {
  RegistrationResult r;
  r.converged = true;
  r.fitness = 0.9;
  r.inlier_rmse = 0.3;
  r.transform = pose(3.0, 0.0, 0.0);
  r.covariance = isotropic(0.002, 0.0002);
  // Well constrained except yaw: H = diag(1e4, 1e4, 1e4, 1e3, 1e3, 10).
  r.hessian = (Vector6d() << 1e4, 1e4, 1e4, 1e3, 1e3, 10.0).finished().asDiagonal();
  return r;
}

LoopCandidate candidateAt(const Eigen::Isometry3d& guess) {
  LoopCandidate c;
  c.match = 2;
  c.query = 40;
  c.initial_guess = guess;
  return c;
}

}  // namespace

TEST(HonestLoopCovariance, TheMisfitGoesAlongTheHessiansWeakAxis) {
  const RegistrationResult r = loopRegistration();
  VerificationConfig c;
  const Matrix6d extra = honestyTerms(r, c);
  // rmse² · H⁻¹: 0.09 / 10 on yaw, 0.09 / 1e4 on x.
  EXPECT_NEAR(extra(5, 5), 0.009, 1e-12);
  EXPECT_NEAR(extra(0, 0), 9e-6, 1e-15);
  EXPECT_NEAR(extra(0, 5), 0.0, 1e-15);
  const VerificationResult v = evaluateRegistration(candidateAt(r.transform), r, c);
  ASSERT_TRUE(v.accepted) << v.reason;
  // The yaw the sandwich claimed (0.2 mrad) is now 95 mrad: a 10 mrad error is within 1 σ.
  EXPECT_GT(std::sqrt(v.closure.covariance(5, 5)), 0.09);
  EXPECT_LT(std::sqrt(v.closure.covariance(0, 0)), 0.011);  // x stays near its floor (1 cm)
  // Off: the sandwich covariance and the floors only, as before.
  c.misfit_scale = 0.0;
  const VerificationResult old = evaluateRegistration(candidateAt(r.transform), r, c);
  EXPECT_NEAR(old.closure.covariance(5, 5), 0.0002 * 0.0002 + 0.001 * 0.001, 1e-15);
}

TEST(HonestLoopCovariance, ALabelOnlyDirectionCarriesNoInformation) {
  RegistrationResult r = loopRegistration();
  r.hessian = (Vector6d() << 1e4, 1e4, 1e4, 1e3, 1e3, 1e3).finished().asDiagonal();
  r.label_only_directions.push_back((Vector6d() << -1, 0, 0, 0, 0, 0).finished());  // a corridor's axis
  VerificationConfig c;
  const VerificationResult v = evaluateRegistration(candidateAt(r.transform), r, c);
  ASSERT_TRUE(v.accepted) << v.reason;
  // Along x the loop says nothing (σ ≥ 100 m); across the corridor it keeps its centimetre.
  EXPECT_LT(v.closure.information(0, 0), 1e-4 + 1e-9);
  EXPECT_GT(v.closure.information(1, 1), 1e3);
  // A loop 0.5 m off along the axis costs nothing in the graph; 5 cm across it costs d² ≈ 22.
  const Vector6d along = (Vector6d() << 0.5, 0, 0, 0, 0, 0).finished();
  const Vector6d across = (Vector6d() << 0, 0.05, 0, 0, 0, 0).finished();
  EXPECT_LT(along.dot(v.closure.information * along), 1e-3);
  EXPECT_GT(across.dot(v.closure.information * across), 20.0);
  c.label_only_sigma = 0.0;
  EXPECT_GT(evaluateRegistration(candidateAt(r.transform), r, c).closure.information(0, 0), 1e3);
}

// The never-worse rule on whole simulated routes (frame-to-map, the default): with loops and
// PGO the map error is at most 2 mm above tracking alone, and run.json says why each rejected
// loop was dropped and whether each optimisation was applied.
namespace {

// Map error of tracking alone and with loops and PGO on one simulated route (plain or property
// ICP), and the PGO run's mean map-anchor NEES against the truth (run.json); checks run.json's
// records of rejected loops and optimisations on the way.
struct PgoComparison {
  std::array<double, 2> error{0, 0};  // without, with PGO
  double anchor_nees = 0.0;
  std::size_t anchors = 0;
};

PgoComparison mapErrorWithoutAndWithPgo(const char* scenario, int seed, bool property) {
  const auto dir = hazmap::test::writeSimulatedSequence(std::string("backend-") + scenario + std::to_string(seed) +
                                                            (property ? "" : "-icp"),
                                                        scenario, seed, 0);
  const Sequence seq = Sequence::open(dir);
  OutputConfig out;
  out.write_pngs = false;
  out.write_viewer = false;
  PgoComparison c;
  auto& error = c.error;
  for (int m = 0; m < 2; ++m) {
    const SlamMethod method = property ? (m ? SlamMethod::PropertyIcpPgo : SlamMethod::PropertyIcp)
                                       : (m ? SlamMethod::IcpPgo : SlamMethod::Icp);
    const SlamConfig config = SlamConfig::forMethod(method);
    const SlamResult r = runSlam(seq, config);
    const auto folder = dir / (std::string("out-") + toString(method));
    const RunSummary s = writeRunOutputs(seq, r, config, out, folder);
    EXPECT_TRUE(s.map_error);
    error[m] = s.map_error ? s.map_error->point.mean : 1e9;
    if (!m) continue;
    std::ifstream in(folder / "run.json");
    const nlohmann::json j = nlohmann::json::parse(in);
    for (const auto& rej : j["loop_closure"]["rejected"]) {
      EXPECT_NE(rej["reason"].get<std::string>(), "none");
      EXPECT_FALSE(rej["detail"].get<std::string>().empty());
    }
    for (const auto& o : j["pose_graph"]["optimisations"]) EXPECT_TRUE(o.contains("applied"));
    c.anchor_nees = j["edge_nees"]["map_anchor"]["mean"].get<double>();
    c.anchors = j["edge_nees"]["map_anchor"]["count"].get<std::size_t>();
  }
  std::filesystem::remove_all(dir);
  return c;
}

}  // namespace

class NeverWorse : public ::testing::TestWithParam<std::pair<const char*, int>> {};

TEST_P(NeverWorse, PgoMapErrorIsAtMostTrackingPlusTwoMillimetres) {
  const auto [scenario, seed] = GetParam();
  const auto error = mapErrorWithoutAndWithPgo(scenario, seed, /*property=*/true).error;
  EXPECT_LE(error[1], error[0] + 0.002) << scenario << " seed " << seed << ": tracking " << error[0]
                                        << " m, with PGO " << error[1] << " m";
}

INSTANTIATE_TEST_SUITE_P(Scenes, NeverWorse,
                         ::testing::Values(std::make_pair("naraha", 1), std::make_pair("naraha", 2),
                                           std::make_pair("corridor", 2), std::make_pair("corridor", 3),
                                           std::make_pair("tanks", 2)),
                         [](const auto& info) { return std::string(info.param.first) + std::to_string(info.param.second); });

// Plain ICP in the tanks' open field: until 2026-12-06 every frame was degenerate (the floor's pairs
// set the robust scale and the weight degeneracy is judged against; the tracker kept the wheel
// guess along ICP's weak directions), so tracking's map placed the return path 20-40 cm and
// 1-2 deg off the outbound one. Map anchors that claimed that relative pose to 2-3 cm turned
// seed 8's whole route by 5 deg (icp 0.41 m, icp+pgo 0.71 m; seed 6 lost 17 mm the same way).
class NeverWorsePlainIcp : public ::testing::TestWithParam<std::pair<const char*, int>> {};

TEST_P(NeverWorsePlainIcp, PgoMapErrorIsAtMostTrackingPlusTwoMillimetres) {
  const auto [scenario, seed] = GetParam();
  const PgoComparison c = mapErrorWithoutAndWithPgo(scenario, seed, /*property=*/false);
  EXPECT_LE(c.error[1], c.error[0] + 0.002) << scenario << " seed " << seed << ": icp " << c.error[0]
                                            << " m, icp+pgo " << c.error[1] << " m";
  // The anchors claim no more than they know: mean NEES at most 2 × 6 (was 117 on tanks 8).
  ASSERT_GT(c.anchors, 10u);
  EXPECT_LE(c.anchor_nees, 12.0) << c.anchors << " map anchors";
}

INSTANTIATE_TEST_SUITE_P(Scenes, NeverWorsePlainIcp,
                         ::testing::Values(std::make_pair("tanks", 8)),
                         [](const auto& info) { return std::string(info.param.first) + std::to_string(info.param.second); });

// The map follows the graph: every local-map point moves with the correction of the scan that
// brought it, identity corrections leave the map as it was, and too few corrections are an error.
TEST(LocalMapReanchor, MovesEachPointWithItsScansCorrection) {
  const ClassTable classes = ClassTable::defaults();
  LocalMapConfig mc;
  mc.voxel_size = 0.5;
  LocalMap map(mc);
  LabeledCloud a, b;
  for (int i = 0; i < 5; ++i) {
    a.push_back(Eigen::Vector3f(0.1f * i, 0.0f, 0.0f), 0);
    b.push_back(Eigen::Vector3f(10.0f + 0.1f * i, 0.0f, 0.0f), 0);
  }
  map.integrate(a, Eigen::Vector3d::Zero(), classes);
  map.integrate(b, Eigen::Vector3d::Zero(), classes);
  ASSERT_EQ(map.integrations(), 2u);
  const LabeledCloud before = map.cloud();
  map.reanchor({Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()}, Eigen::Vector3d::Zero(), classes);
  const LabeledCloud same = map.cloud();
  ASSERT_EQ(same.size(), before.size());
  for (std::size_t i = 0; i < same.size(); ++i) EXPECT_TRUE(same.points[i].isApprox(before.points[i]));
  // Scan b moves 0.3 m up; scan a stays.
  Eigen::Isometry3d up = Eigen::Isometry3d::Identity();
  up.translation().z() = 0.3;
  map.reanchor({Eigen::Isometry3d::Identity(), up}, Eigen::Vector3d::Zero(), classes);
  const LabeledCloud moved = map.cloud();
  ASSERT_EQ(moved.size(), 10u);
  int lifted = 0, kept = 0;
  for (const auto& p : moved.points) {
    if (p.x() > 5.0f) lifted += std::abs(p.z() - 0.3f) < 1e-6f;
    else kept += std::abs(p.z()) < 1e-6f;
  }
  EXPECT_EQ(lifted, 5);
  EXPECT_EQ(kept, 5);
  EXPECT_THROW(map.reanchor({Eigen::Isometry3d::Identity()}, Eigen::Vector3d::Zero(), classes), Error);
}

TEST(OdometryReanchor, NeedsOnePosePerFrameAndTakesTheNewPoses) {
  const ClassTable classes = ClassTable::defaults();
  Odometry odo(classes);
  LabeledCloud scan;
  for (int x = -10; x <= 10; ++x)
    for (int y = -10; y <= 10; ++y) scan.push_back(Eigen::Vector3f(0.5f * x, 0.5f * y, (x * y) % 3 * 0.3f), 0);
  odo.addFrame(scan);
  odo.addFrame(scan, Eigen::Isometry3d::Identity());
  EXPECT_THROW(odo.reanchor({Eigen::Isometry3d::Identity()}), Error);
  const Eigen::Isometry3d shifted = pose(0.4, -0.2, 0.05);
  odo.reanchor({shifted, shifted});
  EXPECT_TRUE(odo.frames().back().pose.isApprox(shifted));
  // The next frame continues from the corrected pose on the moved map.
  const OdometryFrame& f = odo.addFrame(scan, Eigen::Isometry3d::Identity());
  EXPECT_LT((f.pose.translation() - shifted.translation()).norm(), 0.05);
}

// Naraha seed 7 (frame to map): two wheel slips make ICP from the slipped guess fail at frames
// 31–32. Without recovery they fall back to the guess; with their points in the local map the
// rest of the route is tracked 1.05 m off (whole route: map error 0.85 m; first 45 frames:
// 0.32 m). With recovery (odometry.recovery.relocalise, the default) the two frames are re-registered and
// nothing falls back at all. (Keeping fallback frames out of the map, odometry.map_skips_fallback,
// was retired: docs/history/odometry-map-skips.md.)
TEST(FallbackFrames, NarahaSeed7IsNotLost) {
  const auto dir = hazmap::test::writeSimulatedSequence("backend-skip-fallback", "naraha", 7, 45);
  const Sequence seq = Sequence::open(dir);
  OutputConfig out;
  out.write_pngs = false;
  out.write_viewer = false;
  struct Case {
    bool relocalise;
    double error = 0.0;
    std::size_t fallback = 0;
  };
  Case cases[] = {{false}, {true}};
  for (Case& c : cases) {
    SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcp);
    config.odometry.recovery.relocalise = c.relocalise;
    const SlamResult r = runSlam(seq, config);
    c.fallback = countTracking(r.frames).fallback;
    const RunSummary s = writeRunOutputs(seq, r, config, out, dir / (c.relocalise ? "outR" : "out"));
    ASSERT_TRUE(s.map_error);
    c.error = s.map_error->point.mean;
  }
  // Since ICP's correction is measured in the sensor frame (issue 19, 2026-12-02) ICP from the
  // slipped guess passes at frames 31-32 even without recovery: the slips were refused as
  // "diverged" only because a turn 30 m from the world origin read as metres. Nothing falls back
  // any more (map error 0.85 -> 0.015 m). Which frames fall back is chaotic (none here; another
  // machine may see one): what matters is that tracking is not lost, which costs more than a
  // couple of frames and 5 cm of map error.
  for (const Case& c : cases) {
    EXPECT_LE(c.fallback, 2u) << "relocalise " << c.relocalise;
    EXPECT_LT(c.error, 0.05) << "relocalise " << c.relocalise;
  }
  std::filesystem::remove_all(dir);
}
