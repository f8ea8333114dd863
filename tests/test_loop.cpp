// Loop closure: landmarks, constellation candidates, verification rules, consistency, config.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>

#include "hazmap/core/error.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "test_helpers.hpp"
#include "test_loop_scene.hpp"

using namespace hazmap;
using hazmap::test::Patch;

namespace {

double yawDeg(const Eigen::Isometry3d& T) { return rotationAngle(T) * 180.0 / M_PI; }

// -------------------------------------------------------------------------------- landmarks

TEST(LoopLandmarks, ClustersByClassAndDescribesEachCluster) {
  const ClassTable table = ClassTable::defaults();
  // A 2 m × 1 m floor puddle, a heat patch overlapping it in space (different class: separate
  // landmark), a second heat patch 3 m away, and isolated noise points.
  std::vector<Patch> patches = {test::floorPatch(2, 1.0, 0.0, 1.0, 0.5, 12.f),
                                test::floorPatch(1, 1.0, 0.0, 0.3, 0.3, 90.f),
                                test::wallPatch(1, 4.0, 0.0, 1.0, 0.5, 0.0, 70.f)};
  LabeledCloud cloud = test::samplePatches(patches, 0.05);
  cloud.push_back({10.f, 10.f, 0.f}, 1, 0, 0, 50.f);   // label noise: isolated
  cloud.push_back({-5.f, 3.f, 1.f}, 2, 0, 0, 50.f);
  for (int i = 0; i < 200; ++i) cloud.push_back({0.f, -3.f + 0.01f * i, 0.f}, 0);  // class none

  const auto lms = extractLandmarks(cloud, table, {});
  ASSERT_EQ(lms.size(), 3u);
  // Sorted by class: two heat (1), then the water (2).
  EXPECT_EQ(lms[0].class_id, 1);
  EXPECT_EQ(lms[1].class_id, 1);
  EXPECT_EQ(lms[2].class_id, 2);
  const PropertyLandmark& water = lms[2];
  EXPECT_NEAR((water.centroid - Eigen::Vector3d(1.0, 0.0, 0.0)).norm(), 0.0, 1e-4);
  // Uniform 2 m × 1 m rectangle: principal std devs 2/√12, 1/√12, 0.
  EXPECT_NEAR(water.extent(0), 2.0 / std::sqrt(12.0), 0.02);
  EXPECT_NEAR(water.extent(1), 1.0 / std::sqrt(12.0), 0.02);
  EXPECT_NEAR(water.extent(2), 0.0, 1e-4);
  EXPECT_NEAR(std::abs(water.axes.col(0).x()), 1.0, 1e-6);
  EXPECT_EQ(water.point_count, 41u * 21u);
  EXPECT_TRUE(water.has_property_value);
  EXPECT_NEAR(water.mean_property, 12.0, 1e-4);
  EXPECT_NEAR(water.box_max.x() - water.box_min.x(), 2.0, 1e-5);
  // The overlapping small heat patch and the wall patch are distinct clusters.
  std::vector<double> xs = {lms[0].centroid.x(), lms[1].centroid.x()};
  std::sort(xs.begin(), xs.end());
  EXPECT_NEAR(xs[0], 1.0, 1e-4);
  EXPECT_NEAR(xs[1], 4.0, 1e-4);
}

TEST(LoopLandmarks, ToleranceSplitsOrJoinsAndRangeFilters) {
  const ClassTable table = ClassTable::defaults();
  // Two strips of heat points 0.5 m apart (like two scan rings on one puddle).
  LabeledCloud cloud;
  for (int i = 0; i < 30; ++i) {
    cloud.push_back({3.f + 0.05f * i, 0.f, 0.f}, 1);
    cloud.push_back({3.f + 0.05f * i, 0.5f, 0.f}, 1);
  }
  LandmarkConfig c;
  c.cluster_tolerance = 0.4;
  EXPECT_EQ(extractLandmarks(cloud, table, c).size(), 2u);
  c.cluster_tolerance = 0.6;
  ASSERT_EQ(extractLandmarks(cloud, table, c).size(), 1u);
  EXPECT_EQ(extractLandmarks(cloud, table, c)[0].point_count, 60u);
  EXPECT_FALSE(extractLandmarks(cloud, table, c)[0].has_property_value);
  c.max_range = 2.5;  // everything is beyond 3 m
  EXPECT_TRUE(extractLandmarks(cloud, table, c).empty());
  c.max_range = 0;
  c.min_points = 61;
  EXPECT_TRUE(extractLandmarks(cloud, table, c).empty());
  c.cluster_tolerance = 0.0;
  EXPECT_THROW(extractLandmarks(cloud, table, c), Error);
  EXPECT_TRUE(extractLandmarks(LabeledCloud{}, table, {}).empty());
}

TEST(LoopLandmarks, PurityDropsLabelNoiseOnDenseSurfaces) {
  const ClassTable table = ClassTable::defaults();
  // A wall 2 m away sampled every 1 cm (a VLP-16 is that dense at close range), with 0.5 %-like
  // label noise concentrated in one spot (40 heat points among ~10k), and a real heat panel
  // elsewhere on the same wall.
  LabeledCloud cloud;
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < 300; ++i)
    for (int j = 0; j < 150; ++j) {
      const Eigen::Vector3f p(-1.5f + 0.01f * i, 2.0f, 0.01f * j);
      const bool panel = p.x() > 0.5f && p.x() < 1.3f && p.z() > 0.3f && p.z() < 1.1f;
      const bool noise = !panel && p.x() < -0.5f && p.z() < 0.6f && u(rng) < 0.004;
      cloud.push_back(p, (panel || noise) ? 1 : 0);
    }
  LandmarkConfig c;
  const auto lms = extractLandmarks(cloud, table, c);
  ASSERT_EQ(lms.size(), 1u);
  EXPECT_NEAR(lms[0].centroid.x(), 0.9, 0.02);
  EXPECT_GT(lms[0].purity, 0.3);
  c.min_purity = 0.0;  // off: the noise becomes a landmark too
  const auto all = extractLandmarks(cloud, table, c);
  ASSERT_EQ(all.size(), 2u);
  EXPECT_DOUBLE_EQ(all[0].purity, 1.0);
}

TEST(LoopLandmarks, MergeAWindowOfKeyframesIntoOnePlace) {
  const LabeledCloud world = test::samplePatches(test::routePatches());
  const PoseList truth = test::rectangleRoute();
  std::mt19937 rng(11);
  std::vector<std::vector<PropertyLandmark>> lms;
  for (std::size_t k = 0; k < 6; ++k)
    lms.push_back(extractLandmarks(test::observe(world, truth[k], 6.0, 0.02, 0.3, rng),
                                   ClassTable::defaults(), {}));
  const auto place = mergeLandmarks(lms, truth, 0, 5, 5, 1.0);
  // Every landmark seen in the window appears once, at its true position in keyframe 5's frame.
  std::size_t most = 0;
  for (const auto& l : lms) most = std::max(most, l.size());
  EXPECT_GT(place.size(), most);
  std::size_t total_points = 0;
  for (const auto& l : lms)
    for (const auto& x : l) total_points += x.point_count;
  std::size_t merged_points = 0;
  for (const auto& l : place) merged_points += l.point_count;
  EXPECT_EQ(merged_points, total_points);
  const auto patches = test::routePatches();
  for (const auto& l : place) {
    const Eigen::Vector3d w = truth[5] * l.centroid;
    double nearest = 1e9;
    for (const auto& p : patches)
      if (p.cls == l.class_id) nearest = std::min(nearest, (p.center - w).norm());
    EXPECT_LT(nearest, 0.8) << "merged landmark at " << w.transpose();
  }
  for (std::size_t i = 0; i < place.size(); ++i)
    for (std::size_t j = i + 1; j < place.size(); ++j)
      if (place[i].class_id == place[j].class_id)
        EXPECT_GT((place[i].centroid - place[j].centroid).norm(), 1.0);
  EXPECT_THROW(mergeLandmarks(lms, truth, 3, 9, 5, 1.0), Error);
}

// ------------------------------------------------------------------------ constellations

std::vector<PropertyLandmark> landmarksSeenFrom(const LabeledCloud& world, const Eigen::Isometry3d& pose,
                                                double range, std::mt19937& rng) {
  return extractLandmarks(test::observe(world, pose, range, 0.02, 0.3, rng), ClassTable::defaults(), {});
}

TEST(LoopConstellation, RecoversRelativePosePlanar) {
  const LabeledCloud world = test::samplePatches(test::routePatches());
  std::mt19937 rng(7);
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, 0.5, 0.5, 0, 0, 0.3);
  const Eigen::Isometry3d Tb = fromXyzRpy(3.0, -0.5, 0.5, 0, 0, 1.2);
  const auto la = landmarksSeenFrom(world, Ta, 10.0, rng);
  const auto lb = landmarksSeenFrom(world, Tb, 10.0, rng);
  ASSERT_GE(la.size(), 4u);
  ASSERT_GE(lb.size(), 4u);
  const auto m = matchConstellations(lb, la, {});
  ASSERT_TRUE(m.has_value());
  EXPECT_FALSE(m->ambiguous);
  EXPECT_GE(m->inliers.size(), 4u);
  const Eigen::Isometry3d truth = Ta.inverse() * Tb;
  const Eigen::Isometry3d err = truth.inverse() * m->T_match_query;
  EXPECT_LT(translationNorm(err), 0.1);
  EXPECT_LT(yawDeg(err), 1.0);
  EXPECT_LT(m->rmse, 0.3);  // partly seen patches (range cut, dropouts) shift centroids
}

TEST(LoopConstellation, RecoversRelativePoseFull3D) {
  const LabeledCloud world = test::samplePatches(test::routePatches());
  std::mt19937 rng(8);
  // The second view is tilted (a crawler on a ramp): a planar model cannot explain it.
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, 0.5, 0.5, 0, 0, 0.3);
  const Eigen::Isometry3d Tb = fromXyzRpy(3.0, -0.5, 0.9, 0.12, -0.15, 1.2);
  const auto la = landmarksSeenFrom(world, Ta, 10.0, rng);
  const auto lb = landmarksSeenFrom(world, Tb, 10.0, rng);
  ConstellationConfig c;
  c.model = ConstellationModel::Full3D;
  const auto m = matchConstellations(lb, la, c);
  ASSERT_TRUE(m.has_value());
  const Eigen::Isometry3d err = (Ta.inverse() * Tb).inverse() * m->T_match_query;
  EXPECT_LT(translationNorm(err), 0.1);
  EXPECT_LT(yawDeg(err), 1.0);
}

TEST(LoopConstellation, FindsLoopUnderLargeDriftWhereDistanceSearchFails) {
  const LabeledCloud world = test::samplePatches(test::routePatches());
  const PoseList truth = test::rectangleRoute();
  // 6 % scale error and 0.5°/step yaw bias: the estimate ends metres from the start.
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  const std::size_t query = truth.size() - 1;
  const double drift = (estimate[query].translation() - truth[query].translation()).norm();
  ASSERT_GT(drift, 5.0) << "the scenario must have several metres of drift";

  std::mt19937 rng(3);
  std::vector<std::vector<PropertyLandmark>> lms;
  for (const auto& T : truth) lms.push_back(landmarksSeenFrom(world, T, 10.0, rng));

  CandidateSearchConfig cfg;
  // Distance search on the drifted estimate: no true loop among its candidates.
  for (const auto& c : findDistanceCandidates(query, estimate, cfg)) {
    const double true_distance = (truth[c.match].translation() - truth[query].translation()).norm();
    EXPECT_GT(true_distance, 3.0) << "distance search found keyframe " << c.match;
  }
  // Constellations: the best candidate is a true revisit with the true relative pose.
  const auto cands = findConstellationCandidates(query, lms, cfg);
  ASSERT_FALSE(cands.empty());
  const LoopCandidate& best = cands.front();
  EXPECT_EQ(best.source, CandidateSource::Constellation);
  EXPECT_LT((truth[best.match].translation() - truth[query].translation()).norm(), 3.0)
      << "best match keyframe " << best.match;
  const Eigen::Isometry3d err = (truth[best.match].inverse() * truth[query]).inverse() * best.initial_guess;
  EXPECT_LT(translationNorm(err), 0.3);
  EXPECT_LT(yawDeg(err), 2.0);
  // Every candidate's guess is the true relative pose (constellations do not lie here).
  for (const auto& c : cands) {
    const Eigen::Isometry3d e = (truth[c.match].inverse() * truth[query]).inverse() * c.initial_guess;
    EXPECT_LT(translationNorm(e), 0.5) << "candidate " << c.match;
  }
  // Recent keyframes are never candidates.
  for (const auto& c : cands) EXPECT_LE(c.match + cfg.min_index_gap, query);
}

TEST(LoopConstellation, RejectsDifferentPlacesAndSymmetricConstellations) {
  // Same classes, different geometry: pairwise distances disagree.
  auto lm = [](ClassId c, double x, double y) {
    PropertyLandmark l;
    l.class_id = c;
    l.centroid = {x, y, 0.0};
    l.extent = {0.4, 0.2, 0.0};
    return l;
  };
  const std::vector<PropertyLandmark> a = {lm(1, 0, 0), lm(2, 4, 0), lm(1, 0, 6), lm(2, 5, 5)};
  const std::vector<PropertyLandmark> b = {lm(1, 1, 1), lm(2, 8, 1), lm(1, 1, 3), lm(2, 2, 9)};
  EXPECT_FALSE(matchConstellations(a, b, {}).has_value());
  // The same constellation, moved: found.
  std::vector<PropertyLandmark> moved = a;
  const Eigen::Isometry3d T = fromXyYaw(3, -2, 2.0);
  for (auto& l : moved) l.centroid = T * l.centroid;
  auto m = matchConstellations(a, moved, {});
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->inliers.size(), 4u);
  EXPECT_LT(translationNorm(T.inverse() * m->T_match_query), 1e-9);
  // Classes matter: relabelling breaks the match.
  std::vector<PropertyLandmark> relabelled = moved;
  for (auto& l : relabelled) l.class_id = l.class_id == 1 ? 2 : 1;
  relabelled[3].class_id = 3;
  EXPECT_FALSE(matchConstellations(a, relabelled, {}).has_value());
  // Property value gate: a 20 °C puddle is not an 80 °C heat source's partner.
  std::vector<PropertyLandmark> hot = a, warm = moved;
  for (auto& l : hot) { l.has_property_value = true; l.mean_property = 80; }
  for (auto& l : warm) { l.has_property_value = true; l.mean_property = 20; }
  ConstellationConfig gated;
  gated.property_value_tolerance = 10;
  EXPECT_FALSE(matchConstellations(hot, warm, gated).has_value());
  EXPECT_TRUE(matchConstellations(hot, warm, {}).has_value());
  // Four identical sources on a square: every 90° rotation fits; flagged ambiguous and never a
  // candidate.
  const std::vector<PropertyLandmark> square = {lm(1, 0, 0), lm(1, 4, 0), lm(1, 4, 4), lm(1, 0, 4)};
  auto s = matchConstellations(square, square, {});
  ASSERT_TRUE(s.has_value());
  EXPECT_TRUE(s->ambiguous);
  std::vector<std::vector<PropertyLandmark>> frames(20, a);
  frames[0] = square;
  frames[19] = square;
  for (const auto& c : findConstellationCandidates(19, frames, {})) EXPECT_NE(c.match, 0u);
}

TEST(LoopConstellation, FacingBreaksTheFlipOfTwoSameClassPanels) {
  // Two identical heat panels on one wall (y = 3, facing south): from two keyframes south of
  // the wall, the pair alone fits the true pose and its 180° flip equally well.
  const std::vector<Patch> patches = {test::wallPatch(1, 0.0, 3.0, 1.0, 0.5, 0.0),
                                      test::wallPatch(1, 4.0, 3.0, 1.0, 0.5, 0.0)};
  const LabeledCloud world = test::samplePatches(patches, 0.05);
  std::mt19937 rng(4);
  const Eigen::Isometry3d Ta = fromXyzRpy(1.0, -1.0, 0.5, 0, 0, 0.2);
  const Eigen::Isometry3d Tb = fromXyzRpy(3.0, -2.0, 0.5, 0, 0, 1.1);
  const auto la = landmarksSeenFrom(world, Ta, 15.0, rng);
  const auto lb = landmarksSeenFrom(world, Tb, 15.0, rng);
  ASSERT_EQ(la.size(), 2u);
  ASSERT_EQ(lb.size(), 2u);
  ConstellationConfig off;
  off.facing_tolerance = 0.0;
  const auto flip = matchConstellations(lb, la, off);
  ASSERT_TRUE(flip.has_value());
  EXPECT_TRUE(flip->ambiguous);
  const auto m = matchConstellations(lb, la, {});
  ASSERT_TRUE(m.has_value());
  EXPECT_FALSE(m->ambiguous);
  const Eigen::Isometry3d err = (Ta.inverse() * Tb).inverse() * m->T_match_query;
  EXPECT_LT(translationNorm(err), 0.1);
  EXPECT_LT(yawDeg(err), 1.0);
}

// ------------------------------------------------------------------------------ verification

RegistrationResult goodRegistration(const Eigen::Isometry3d& T) {
  RegistrationResult r;
  r.transform = T;
  r.converged = true;
  r.fitness = 0.8;
  r.inlier_rmse = 0.05;
  Vector6d d;
  d << 1e-4, 2e-4, 1e-4, 1e-6, 1e-6, 4e-6;
  r.covariance = d.asDiagonal();
  return r;
}

TEST(LoopVerification, AcceptanceRules) {
  LoopCandidate cand;
  cand.query = 40;
  cand.match = 3;
  cand.initial_guess = fromXyYaw(1.0, 0.5, 0.2);
  const Eigen::Isometry3d refined = fromXyYaw(1.1, 0.45, 0.21);
  VerificationConfig cfg;
  auto ok = evaluateRegistration(cand, goodRegistration(refined), cfg);
  ASSERT_TRUE(ok.accepted) << ok.reason;
  EXPECT_EQ(ok.closure.from, 3u);
  EXPECT_EQ(ok.closure.to, 40u);
  EXPECT_TRUE(ok.closure.T_from_to.isApprox(refined));
  EXPECT_TRUE((ok.closure.information * ok.closure.covariance).isApprox(Matrix6d::Identity(), 1e-9));
  // The floors are added: x variance 1e-4 + 0.01² = 2e-4 → information 5000.
  EXPECT_NEAR(ok.closure.information(0, 0), 1.0 / (1e-4 + 1e-4), 1e-6);

  auto expectReject = [&](RegistrationResult r, const std::string& word) {
    auto v = evaluateRegistration(cand, r, cfg);
    EXPECT_FALSE(v.accepted);
    EXPECT_NE(v.reason.find(word), std::string::npos) << v.reason;
  };
  RegistrationResult r = goodRegistration(refined);
  r.converged = false;
  expectReject(r, "converge");
  r = goodRegistration(refined);
  r.fitness = 0.2;
  expectReject(r, "fitness");
  r = goodRegistration(refined);
  r.inlier_rmse = 0.6;
  expectReject(r, "rmse");
  r = goodRegistration(refined);
  r.degenerate_directions.push_back(Vector6d::Unit(0));
  expectReject(r, "degenerate");
  r = goodRegistration(fromXyYaw(4.5, 0.5, 0.2));  // slid 3.5 m from the guess
  expectReject(r, "moved");
  r = goodRegistration(refined);
  r.covariance(1, 1) = 1.0;  // 1 m sigma along y
  expectReject(r, "translation sigma");
  r = goodRegistration(refined);
  r.covariance(5, 5) = 0.01;  // 0.1 rad sigma in yaw
  expectReject(r, "rotation sigma");
  r = goodRegistration(refined);
  r.covariance(2, 2) = -1e-3;
  expectReject(r, "positive definite");
  r = goodRegistration(refined);
  r.covariance(0, 0) = std::nan("");
  expectReject(r, "non-finite");
  // Degenerate registrations are accepted when the user allows them.
  r = goodRegistration(refined);
  r.degenerate_directions.push_back(Vector6d::Unit(0));
  cfg.reject_degenerate = false;
  EXPECT_TRUE(evaluateRegistration(cand, r, cfg).accepted);
}

// ------------------------------------------------------------------------------- consistency

LoopClosure loopBetween(const PoseList& truth, std::size_t from, std::size_t to,
                        const Eigen::Isometry3d& error = Eigen::Isometry3d::Identity()) {
  LoopClosure l;
  l.from = from;
  l.to = to;
  l.T_from_to = error * truth[from].inverse() * truth[to];
  Vector6d d;
  d << 0.05 * 0.05, 0.05 * 0.05, 0.05 * 0.05, 0.01 * 0.01, 0.01 * 0.01, 0.01 * 0.01;
  l.covariance = d.asDiagonal();
  l.information = l.covariance.inverse();
  return l;
}

TEST(LoopConsistency, ChiSquareQuantile) {
  EXPECT_NEAR(chiSquareQuantile(6, 0.999), 22.458, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(6, 0.95), 12.592, 1e-3);
  EXPECT_THROW(chiSquareQuantile(6, 1.0), Error);
  EXPECT_NEAR(chiSquareQuantile(3, 0.95), 7.815, 1e-3);
  EXPECT_NEAR(chiSquareQuantile(3, 0.99), 11.345, 1e-3);
  EXPECT_THROW(chiSquareQuantile(4, 0.95), Error);
}

TEST(LoopConsistency, DriftGateScalesWithPathLength) {
  const PoseList truth = test::rectangleRoute();
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  ConsistencyConfig cfg;
  // A true loop across the whole route (60 m of drift budget) passes although the estimate is
  // metres off.
  const LoopClosure far = loopBetween(truth, 0, 60);
  ASSERT_GT(translationNorm((estimate[0].inverse() * estimate[60]).inverse() * far.T_from_to), 4.0);
  const GateResult g = driftGate(far, estimate, cfg);
  EXPECT_TRUE(g.accepted) << g.mahalanobis2;
  EXPECT_NEAR(g.path_length, 60.0 * 1.06, 1.0);
  // A loop 4 m off between keyframes 10 m apart along the route (identical-tank confusion)
  // fails.
  const LoopClosure wrong = loopBetween(truth, 10, 20, fromXyYaw(4.0, 0.0, 0.0));
  EXPECT_FALSE(driftGate(wrong, truth, cfg).accepted) << driftGate(wrong, truth, cfg).mahalanobis2;
  // The same error passes a gate with a huge drift budget: the gate is only as strict as its
  // drift model.
  cfg.translation_drift_per_metre = 1.0;
  EXPECT_TRUE(driftGate(wrong, truth, cfg).accepted);
}

TEST(LoopConsistency, PairwiseConsistencyDropsInjectedWrongLoops) {
  const PoseList truth = test::rectangleRoute();
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  std::vector<LoopClosure> loops = {
      loopBetween(truth, 0, 60), loopBetween(truth, 1, 59, fromXyYaw(0.03, -0.02, 0.004)),
      loopBetween(truth, 2, 58),
      // Wrong loops: right keyframes but 3 m / 20° off, and a wrong pairing.
      loopBetween(truth, 3, 57, fromXyYaw(3.0, 0.0, 0.35)), loopBetween(truth, 25, 56),
      loopBetween(truth, 0, 55, fromXyYaw(-2.5, 1.0, 0.0))};
  // Keyframe 25 is far from 56 in truth: build the wrong pairing as "measured" identity-ish.
  loops[4].T_from_to = fromXyYaw(0.5, 0.2, 0.1);
  const auto keep = consistentSubset(loops, estimate, {});
  EXPECT_EQ(keep, (std::vector<std::size_t>{0, 1, 2}));
  // With only wrong loops mutually inconsistent, at most one survives.
  std::vector<LoopClosure> wrong = {loops[3], loops[4], loops[5]};
  EXPECT_LE(consistentSubset(wrong, estimate, {}).size(), 1u);
  EXPECT_TRUE(consistentSubset({}, estimate, {}).empty());
}

// Hundreds of loops (a long mission, the greedy path): the subset kept is consistent pair by pair
// as pairwiseDistance2 says (the subset reads path lengths as differences of one cumulative sum,
// the public functions sum along the path), and every loop left out fails with one kept.
namespace {

// `n` loops between the rectangle route's first and last 20 keyframes: one in nine (k % 9 == 4)
// 2.5 m / 15° off, the others off by `right(k)`.
std::vector<LoopClosure> loopsAcrossTheRoute(const PoseList& truth, std::size_t n,
                                             const std::function<Eigen::Isometry3d(std::size_t)>& right) {
  std::vector<LoopClosure> loops;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t from = k % 20, to = truth.size() - 1 - (k * 7) % 20;
    loops.push_back(loopBetween(truth, from, to, k % 9 == 4 ? fromXyYaw(2.5, 0.5, 0.26) : right(k)));
  }
  return loops;
}

}  // namespace

TEST(LoopConsistency, ManyLoopsKeepAPairwiseConsistentMaximalSubset) {
  const PoseList truth = test::rectangleRoute();
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  const std::vector<LoopClosure> loops =
      loopsAcrossTheRoute(truth, 150, [](std::size_t) { return fromXyYaw(0.01, -0.01, 0.002); });
  const ConsistencyConfig cfg;
  const auto keep = consistentSubset(loops, estimate, cfg);
  const double threshold = chiSquareQuantile(6, cfg.gate_probability);
  ASSERT_GT(keep.size(), 100u);
  for (std::size_t a : keep) {
    EXPECT_NE(a % 9, 4u) << "a wrong loop kept: " << a;
    for (std::size_t b : keep) EXPECT_LE(pairwiseDistance2(loops[a], loops[b], estimate, cfg), threshold) << a << ", " << b;
  }
  for (std::size_t c = 0; c < loops.size(); ++c) {
    if (std::find(keep.begin(), keep.end(), c) != keep.end()) continue;
    bool fails_with_one = false;
    for (std::size_t a : keep) fails_with_one = fails_with_one || pairwiseDistance2(loops[c], loops[a], estimate, cfg) > threshold;
    EXPECT_TRUE(fails_with_one) << c;
  }
}

// A long mission's back end asks for the consistent loops before every optimisation while the list
// grows and loses the loops an optimisation drops: beyond 64 loops the incremental subset tests
// each pair once (the calls' pair tests grow as new × all, not all² per call), and under an
// unchanged estimate it answers exactly what consistentSubset answers from scratch.
TEST(LoopConsistency, IncrementalSubsetEqualsTheSubsetFromScratchAndTestsEachPairOnce) {
  const PoseList truth = test::rectangleRoute();
  const PoseList estimate = test::driftedRoute(truth, 0.06, 0.5 * M_PI / 180.0);
  const std::vector<LoopClosure> all =
      loopsAcrossTheRoute(truth, 200, [](std::size_t k) { return fromXyYaw(0.01, -0.01, 0.002 * double(k % 3)); });
  IncrementalConsistency incremental;
  std::vector<LoopClosure> loops;
  std::size_t beyond_64_tests = 0, from_scratch_tests = 0;
  for (std::size_t k = 0; k < all.size(); ++k) {
    loops.push_back(all[k]);
    if (k % 25 == 24) loops.erase(loops.begin() + 30);  // a loop the optimisation dropped
    if (k % 3 != 0) continue;                           // several new loops between calls
    const std::size_t tests_before = incremental.pairTests();
    ASSERT_EQ(incremental.subset(loops, estimate), consistentSubset(loops, estimate)) << k;
    if (loops.size() <= 70) continue;
    beyond_64_tests += incremental.pairTests() - tests_before;
    from_scratch_tests += loops.size() * (loops.size() - 1) / 2;
  }
  ASSERT_GT(loops.size(), 150u);
  // Remembered, a pair is tested once: at most all pairs of all loops ever added, against
  // n(n−1)/2 at every call from scratch.
  EXPECT_GT(beyond_64_tests, 0u);
  EXPECT_LE(beyond_64_tests, all.size() * (all.size() - 1) / 2);
  EXPECT_LT(10 * beyond_64_tests, from_scratch_tests);
  // Loops dropped below 64 again: exact as before.
  loops.resize(40);
  EXPECT_EQ(incremental.subset(loops, estimate), consistentSubset(loops, estimate));
  EXPECT_THROW(incremental.subset(all, PoseList(truth.begin(), truth.begin() + 10)), Error);
}

// ----------------------------------------------------------------------------------- config

TEST(LoopConfig, YamlRoundTripAndErrors) {
  LoopClosureConfig c;
  c.method = CandidateMethod::Both;
  c.landmarks.cluster_tolerance = 0.9;
  c.candidates.constellation.model = ConstellationModel::Full3D;
  c.candidates.constellation.min_inliers = 4;
  c.verification.registration.max_iterations = 40;
  c.verification.registration.index = SpatialIndexKind::VoxelHash;
  c.consistency.gate_probability = 0.99;
  const LoopClosureConfig back = LoopClosureConfig::fromYamlString(c.toYamlString(), "cfg.yaml");
  EXPECT_EQ(back.toYamlString(), c.toYamlString());
  EXPECT_EQ(back.method, CandidateMethod::Both);
  EXPECT_EQ(back.candidates.constellation.model, ConstellationModel::Full3D);
  EXPECT_EQ(back.verification.registration.max_iterations, 40);
  EXPECT_EQ(back.verification.registration.index, SpatialIndexKind::VoxelHash);
  EXPECT_DOUBLE_EQ(back.landmarks.cluster_tolerance, 0.9);

  // Partial files keep defaults; the section may be top level.
  const auto partial = LoopClosureConfig::fromYamlString("candidates: {min_index_gap: 5}\n", "p.yaml");
  EXPECT_EQ(partial.candidates.min_index_gap, 5u);
  EXPECT_DOUBLE_EQ(partial.verification.max_rmse, VerificationConfig{}.max_rmse);

  auto expectError = [](const std::string& yaml, const std::string& needle) {
    try {
      LoopClosureConfig::fromYamlString(yaml, "bad.yaml");
      ADD_FAILURE() << "no error for " << yaml;
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind("bad.yaml", 0), 0u) << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos);
    }
  };
  expectError("loop_closure: {landmarks: {cluster_tolerence: 1}}", "unknown key 'cluster_tolerence'");
  expectError("loop_closure: {landmarks: {cluster_tolerance: -1}}", "cluster_tolerance");
  expectError("loop_closure: {method: magic}", "method");
  expectError("loop_closure: {resident_keyframes: 0}", "resident_keyframes");
  expectError("loop_closure: {candidates: {constellation: {min_inliers: x}}}", "min_inliers");
  expectError("loop_closure: {consistency: {gate_probability: 1.5}}", "gate_probability");
  expectError("loop_closure: [1, 2]", "mapping");
  expectError("loop_closure: {verification: {registration: {metric: p2p}}}", "metric");
  expectError("{{{", "invalid YAML");

  const auto dir = test::scratchDir();
  std::ofstream(dir / "loop.yaml") << "loop_closure:\n  method: distance\n";
  EXPECT_EQ(LoopClosureConfig::fromYamlFile(dir / "loop.yaml").method, CandidateMethod::Distance);
  EXPECT_THROW(LoopClosureConfig::fromYamlFile(dir / "missing.yaml"), Error);
}

}  // namespace
