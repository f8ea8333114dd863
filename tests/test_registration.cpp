// Property-aware ICP: correspondence rule, solvers, determinism, covariance, degeneracy, bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/preprocess/spatial_index.hpp"
#include "hazmap/preprocess/top_k.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "test_helpers.hpp"
#include "test_registration_scenes.hpp"

using namespace hazmap;
using hazmap::test::rotErrDeg;
using hazmap::test::transErr;
using hazmap::test::corridorScene;
using hazmap::test::roomScene;
using hazmap::test::samplePatches;

namespace {

std::string fmtVec(const Vector6d& v) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "[%.3f %.3f %.3f %.3f %.3f %.3f]", v(0), v(1), v(2), v(3), v(4), v(5));
  return buf;
}

struct Pair {
  LabeledCloud source, target;
  Eigen::Isometry3d truth;
};

Pair roomPair(unsigned seed, double noise, std::size_t n = 20000) {
  std::mt19937 rng(seed);
  Pair p;
  p.truth = fromXyzRpy(0.35, -0.2, 0.05, 0.01, -0.015, 0.08);  // target ← source
  const auto scene = roomScene();
  p.target = samplePatches(scene, n, rng, noise);
  p.source = samplePatches(scene, n, rng, noise, p.truth.inverse());
  return p;
}

/// The pair registered from the identity with the default class table.
RegistrationResult registerPair(const Pair& p, const RegistrationConfig& cfg) {
  return registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
}

}  // namespace

TEST(SpatialIndex, VoxelHashMatchesBruteForceAndKdTree) {
  std::mt19937 rng(3);
  const auto cloud = samplePatches(roomScene(), 3000, rng, 0.01);
  const VoxelHashIndex voxel(cloud.points, {}, 0.4f, 1.5f);
  const KdTreeIndex kd(cloud.points, {});
  std::uniform_real_distribution<float> u(-11.f, 11.f), uz(-1.f, 5.f);
  std::vector<Neighbor> knn_v, knn_k;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3f q(u(rng), u(rng) * 0.6f, uz(rng));
    const float r = trial % 2 ? 1.5f : 0.6f;
    float best = r * r;
    std::int64_t brute = -1;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      const float d2 = (cloud.points[i] - q).squaredNorm();
      if (d2 < best) { best = d2; brute = static_cast<std::int64_t>(i); }
    }
    float dv = -1, dk = -1;
    const auto iv = voxel.nearest(q, r * r, dv);
    const auto ik = kd.nearest(q, r * r, dk);
    ASSERT_EQ(iv >= 0, brute >= 0) << trial;
    ASSERT_EQ(ik >= 0, brute >= 0) << trial;
    if (brute >= 0) {
      EXPECT_FLOAT_EQ(dv, best);
      EXPECT_FLOAT_EQ(dk, best);
    }
    voxel.kNearest(q, 8, r * r, knn_v);
    kd.kNearest(q, 8, r * r, knn_k);
    ASSERT_EQ(knn_v.size(), knn_k.size()) << trial;
    for (std::size_t k = 0; k < knn_v.size(); ++k) EXPECT_FLOAT_EQ(knn_v[k].distance2, knn_k[k].distance2);
  }
}

TEST(SpatialIndex, TopKKeepsTheSmallestSortedWithTiesInArrivalOrder) {
  std::vector<Neighbor> buffer{{99, 0.f}};  // stale contents are replaced
  TopK<Neighbor> top(buffer, 3, 10.f);
  for (const Neighbor n : {Neighbor{0, 5.f}, Neighbor{1, 2.f}, Neighbor{2, 12.f}, Neighbor{3, 2.f},
                           Neighbor{4, 7.f}, Neighbor{5, 1.f}, Neighbor{6, 2.f}})
    top.push(n);
  top.finish();
  ASSERT_EQ(buffer.size(), 3u);
  EXPECT_EQ(buffer[0].index, 5u);  // 1
  EXPECT_EQ(buffer[1].index, 1u);  // 2, first of the ties
  EXPECT_EQ(buffer[2].index, 3u);  // 2, second; the third tie (6) does not displace it
  EXPECT_FLOAT_EQ(top.bound(), 2.f);
  TopK<Neighbor> few(buffer, 5, 3.f);  // fewer candidates than k, one beyond the radius
  few.push({7, 4.f});
  few.push({8, 0.5f});
  few.finish();
  ASSERT_EQ(buffer.size(), 1u);
  EXPECT_EQ(buffer[0].index, 8u);
  TopK<Neighbor> none(buffer, 0, 3.f);
  none.push({9, 0.1f});
  none.finish();
  EXPECT_TRUE(buffer.empty());
}

TEST(SpatialIndex, SubsetIndexesOnlyItsIds) {
  LabeledCloud c;
  c.push_back({0, 0, 0});
  c.push_back({0.1f, 0, 0});
  c.push_back({5, 0, 0});
  const std::vector<std::uint32_t> ids{2};
  const VoxelHashIndex v(c.points, ids, 0.5f, 10.f);
  float d2;
  EXPECT_EQ(v.nearest({0, 0, 0}, 100.f, d2), 2);
  EXPECT_FLOAT_EQ(d2, 25.f);
  EXPECT_EQ(v.nearest({0, 0, 0}, 1.f, d2), -1);
  EXPECT_THROW(VoxelHashIndex(c.points, {}, 0.f, 1.f), Error);
}

TEST(Normals, PlaneNormalsPointToViewpoint) {
  std::mt19937 rng(1);
  LabeledCloud c;
  std::uniform_real_distribution<float> u(-2, 2);
  for (int i = 0; i < 500; ++i) c.push_back({u(rng), u(rng), -1.0f});
  const auto n = estimateNormals(c, NormalConfig{});
  for (const auto& v : n) EXPECT_NEAR(v.z(), 1.0f, 1e-4);
}

TEST(PropertyCorrespondence, FollowsEquationTwo) {
  ClassTable table = ClassTable::defaults();  // heat radius 3 m, α from the table
  LabeledCloud target;
  target.push_back({0.1f, 0, 0}, 0);   // 0: none, close
  target.push_back({0.8f, 0, 0}, 1);   // 1: heat at 0.8 m
  target.push_back({0, 2.5f, 0}, 2);   // 2: water at 2.5 m
  RegistrationConfig cfg;
  cfg.metric = IcpMetric::PointToPoint;
  table.mismatch_penalty = 1.0;
  {
    const RegistrationTarget t(target, table, cfg);
    // heat query: heat at d²=0.64 beats none at 0.01 + α = 1.01
    auto m = t.match({0, 0, 0}, 1, NAN);
    EXPECT_EQ(m.index, 1);
    EXPECT_FALSE(m.cross_class);
    // none query: the none point
    m = t.match({0, 0, 0}, 0, NAN);
    EXPECT_EQ(m.index, 0);
    // water query: water at 6.25 > none at 1.01 → cross-class none, penalised
    m = t.match({0, 0, 0}, 2, NAN);
    EXPECT_EQ(m.index, 0);
    EXPECT_TRUE(m.cross_class);
    EXPECT_NEAR(m.cost, 0.01 + 1.0, 1e-5);
  }
  table.mismatch_penalty = 10.0;  // large α: the wider same-class radius wins
  {
    const RegistrationTarget t(target, table, cfg);
    const auto m = t.match({0, 0, 0}, 2, NAN);
    EXPECT_EQ(m.index, 2);
    EXPECT_NEAR(m.distance2, 6.25, 1e-5);
  }
  cfg.use_classes = false;  // plain ICP: nearest point whatever its class
  {
    const RegistrationTarget t(target, table, cfg);
    EXPECT_EQ(t.match({0, 0, 0}, 2, NAN).index, 0);
    EXPECT_EQ(t.match({0, 0, 0}, 1, NAN).index, 0);
    EXPECT_EQ(t.match({0, 5, 0}, 1, NAN).index, -1);  // beyond 1 m
  }
}

// ICP bounds each search by the cost of the previous iteration's partner (costBound): the answer
// must be exactly the unbounded one, for labelled and plain matching, whatever the previous
// partner was (near, far, another class, outside its gate).
TEST(PropertyCorrespondence, PreviousPartnerBoundKeepsTheAnswer) {
  ClassTable table = ClassTable::defaults();
  table.mismatch_penalty = 0.3;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::uniform_int_distribution<int> cls(0, 3);
  LabeledCloud target;
  for (int i = 0; i < 3000; ++i)
    target.push_back({u(rng), u(rng), 0.3f * u(rng)}, static_cast<ClassId>(cls(rng) == 3 ? cls(rng) : 0));
  std::uniform_int_distribution<int> pick(-1, 2999);
  for (const bool classes : {true, false}) {
    RegistrationConfig cfg;
    cfg.use_classes = classes;
    const RegistrationTarget t(target, table, cfg);
    int bounded = 0;
    for (int q = 0; q < 3000; ++q) {
      const Eigen::Vector3f p(u(rng), u(rng), 0.3f * u(rng));
      const auto c = static_cast<ClassId>(cls(rng));
      const std::int64_t prev = pick(rng);
      const float bound = t.costBound(p, c, prev, classes);
      bounded += std::isfinite(bound);
      const TargetMatch free = classes ? t.match(p, c, NAN) : t.nearestAnyClass(p, c);
      const TargetMatch tight = classes ? t.match(p, c, NAN, bound) : t.nearestAnyClass(p, c, bound);
      ASSERT_EQ(free.index, tight.index) << "query " << q << " class " << int(c) << " prev " << prev;
      if (free.index >= 0) EXPECT_LE(free.cost, bound);
    }
    EXPECT_GT(bounded, 100);  // the test exercised the bound
  }
}

class RoomRegistration : public ::testing::TestWithParam<std::tuple<bool, IcpMetric>> {};

TEST_P(RoomRegistration, RecoversTheTransform) {
  const auto [use_classes, metric] = GetParam();
  const Pair p = roomPair(7, 0.01);
  RegistrationConfig cfg;
  cfg.use_classes = use_classes;
  cfg.metric = metric;
  cfg.max_iterations = 150;  // point-to-point between independent samplings converges slowly
  const auto r = registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(),
                                ClassTable::defaults(), cfg);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(transErr(r.transform, p.truth), 0.01);
  EXPECT_LT(rotErrDeg(r.transform, p.truth), 0.1);
  EXPECT_GT(r.fitness, 0.95);
  EXPECT_LT(r.inlier_rmse, 0.15);
  EXPECT_TRUE(r.degenerate_directions.empty());
  EXPECT_TRUE(r.covariance.allFinite());
  EXPECT_GT(r.covariance.diagonal().minCoeff(), 0.0);
  EXPECT_NEAR(r.residual_sigma, metric == IcpMetric::PointToPlane ? 0.014 : 0.03, 0.03);
}

INSTANTIATE_TEST_SUITE_P(All, RoomRegistration,
                         ::testing::Combine(::testing::Bool(),
                                            ::testing::Values(IcpMetric::PointToPoint,
                                                              IcpMetric::PointToPlane)));

TEST(Registration, IdenticalAcrossThreadCountsAndIndexes) {
  const Pair p = roomPair(11, 0.02);
  RegistrationConfig cfg;
  cfg.threads = 1;
  const auto a = registerPair(p, cfg);
  cfg.threads = 2;
  const auto b = registerPair(p, cfg);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_TRUE(a.transform.matrix() == b.transform.matrix());  // bitwise
  EXPECT_TRUE(a.covariance == b.covariance);
  cfg.index = SpatialIndexKind::KdTree;
  const auto c = registerPair(p, cfg);
  EXPECT_EQ(a.iterations, c.iterations);
  EXPECT_LT(transErr(a.transform, c.transform), 1e-6);
}

TEST(Registration, PrebuiltTargetGivesTheSameResult) {
  const Pair p = roomPair(5, 0.01);
  RegistrationConfig cfg;
  const auto table = ClassTable::defaults();
  const RegistrationTarget target(p.target, table, cfg);
  const auto a = registerClouds(p.source, target, Eigen::Isometry3d::Identity(), table, cfg);
  const auto b = registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(), table, cfg);
  EXPECT_TRUE(a.transform.matrix() == b.transform.matrix());
  RegistrationConfig other = cfg;
  other.max_correspondence_distance = 2.0;
  EXPECT_THROW(registerClouds(p.source, target, Eigen::Isometry3d::Identity(), table, other), Error);
}

// A target estimates a normal only when ICP first pairs its point: a source that sees half the
// room leaves most of the other half's normals unestimated, and every normal, estimated during
// ICP or afterwards by normals(), is the one an eager estimate gives (bit for bit).
TEST(Registration, TargetNormalsAreEstimatedOnFirstUse) {
  const Pair p = roomPair(7, 0.01);
  std::vector<std::size_t> half;
  for (std::size_t i = 0; i < p.source.size(); ++i)
    if (p.source.points[i].x() < 0.0f) half.push_back(i);
  const LabeledCloud source = p.source.select(half);
  RegistrationConfig cfg;
  const auto table = ClassTable::defaults();
  const RegistrationTarget target(p.target, table, cfg);
  NormalConfig nc;
  nc.neighbors = cfg.normal_neighbors;
  nc.radius = cfg.normal_radius;
  const float cell = static_cast<float>(cfg.max_correspondence_distance);
  const VoxelHashIndex index(target.cloud().points, {}, cell, cell);
  const std::vector<Eigen::Vector3f> eager = estimateNormals(target.cloud(), index, nc);
  EXPECT_TRUE(target.normalsComputed().size() == eager.size());
  const auto r = registerClouds(source, target, Eigen::Isometry3d::Identity(), table, cfg);
  EXPECT_TRUE(r.converged) << r.reason;
  std::size_t with_normal = 0, estimated = 0, differ = 0;
  for (std::size_t j = 0; j < eager.size(); ++j) {
    with_normal += !eager[j].isZero();
    const Eigen::Vector3f& n = target.normalsComputed()[j];
    estimated += !n.isZero();
    differ += !n.isZero() && n != eager[j];
  }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(estimated, with_normal / 5);
  EXPECT_LT(estimated, with_normal * 3 / 4) << estimated << " of " << with_normal;
  EXPECT_TRUE(target.normals() == eager);
  // The same registration against a fresh target (normals estimated inside ICP) is identical.
  const auto again = registerClouds(source, p.target, Eigen::Isometry3d::Identity(), table, cfg);
  EXPECT_TRUE(again.transform.matrix() == r.transform.matrix());
}

// Many noise draws of the same synthetic pair: the spread of the estimates must match the
// predicted covariance within a factor of two on every axis.
void monteCarlo(IcpMetric metric, bool resample) {
  const auto scene = roomScene();
  const Eigen::Isometry3d truth = fromXyzRpy(0.2, -0.1, 0.02, 0.005, -0.01, 0.05);
  std::mt19937 base_rng(2024);
  const double sigma = 0.02;
  // Fixed underlying sample points (point-to-point: true correspondences exist).
  const LabeledCloud clean = samplePatches(scene, 2500, base_rng, 0.0);
  RegistrationConfig cfg;
  cfg.metric = metric;
  cfg.use_classes = true;
  const int draws = 150;
  std::vector<Vector6d> errors;
  Matrix6d predicted = Matrix6d::Zero();
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (int d = 0; d < draws; ++d) {
    std::mt19937 rng(1000 + d);
    LabeledCloud target, source;
    if (resample) {
      target = samplePatches(scene, 2500, rng, sigma);
      source = samplePatches(scene, 2500, rng, sigma, truth.inverse());
    } else {
      target = clean;
      source = clean.transformed(truth.inverse());
      for (auto& q : target.points) q += sigma * Eigen::Vector3f(g(rng), g(rng), g(rng));
      for (auto& q : source.points) q += sigma * Eigen::Vector3f(g(rng), g(rng), g(rng));
    }
    const auto r = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
    ASSERT_TRUE(r.converged) << r.reason;
    errors.push_back(se3Log(r.transform * truth.inverse()));  // left perturbation
    predicted += r.covariance;
  }
  predicted /= draws;
  Vector6d mean = Vector6d::Zero();
  for (const auto& e : errors) mean += e;
  mean /= draws;
  Matrix6d empirical = Matrix6d::Zero();
  for (const auto& e : errors) empirical += (e - mean) * (e - mean).transpose();
  empirical /= draws - 1;
  for (int k = 0; k < 6; ++k) {
    const double ratio = empirical(k, k) / predicted(k, k);
    std::printf("axis %d: empirical sd %.3g, predicted sd %.3g, variance ratio %.2f, bias %.2g\n", k,
                std::sqrt(empirical(k, k)), std::sqrt(predicted(k, k)), ratio, mean(k));
    EXPECT_GT(ratio, 0.5) << "axis " << k;
    EXPECT_LT(ratio, 2.0) << "axis " << k;
  }
}

TEST(Covariance, MonteCarloPointToPlane) { monteCarlo(IcpMetric::PointToPlane, true); }
TEST(Covariance, MonteCarloPointToPoint) { monteCarlo(IcpMetric::PointToPoint, false); }

TEST(Degeneracy, CorridorReportsTheAxis) {
  std::mt19937 rng(9);
  const auto scene = corridorScene(40.0, false);
  const Eigen::Isometry3d truth = fromXyzRpy(0.0, 0.05, 0.0, 0.0, 0.0, 0.02);
  const auto target = samplePatches(scene, 8000, rng, 0.01);
  const auto source = samplePatches(scene, 8000, rng, 0.01, truth.inverse());
  RegistrationConfig cfg;
  cfg.use_classes = false;
  const auto r = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  for (const auto& d : r.degenerate_directions) std::printf("degenerate: %s\n", fmtVec(d).c_str());
  ASSERT_EQ(r.degenerate_directions.size(), 1u);
  EXPECT_GT(std::abs(r.degenerate_directions[0](0)), 0.99);
  // the covariance is huge along x and small across
  EXPECT_GT(r.covariance(0, 0), 100 * r.covariance(1, 1));
}

// An open field seen from a low sensor: the floor's pairs (89 %) have millimetre residuals
// whatever the horizontal error. With one robust scale for every ordinary pair (before
// 2026-12-06) that scale was the floor's noise, the pillars' pairs — the only ones that see x, y
// and yaw — were rejected and their directions judged degenerate: 0.34 m / 2.1° from the truth,
// i.e. at the guess, with 2 degenerate directions. Level pairs now get their own scale when
// they are the majority, and degeneracy is judged among the others.
TEST(Registration, FloorDominatedFieldStillFixesTheHorizontal) {
  std::mt19937 rng(12);
  const Eigen::Isometry3d truth = fromXyzRpy(0.3, -0.2, 0.0, 0.0, 0.0, 0.035);  // 2 degrees
  const auto target = hazmap::test::pillarField(8000, 0.002, 60, 0.03, rng);
  const auto source = hazmap::test::pillarField(8000, 0.002, 60, 0.03, rng, truth.inverse());
  RegistrationConfig cfg;
  cfg.use_classes = false;
  const auto r = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  std::printf("pillar field: error %.4f m / %.3f deg, %d iterations, %zu degenerate direction(s)\n",
              transErr(r.transform, truth), rotErrDeg(r.transform, truth), r.iterations,
              r.degenerate_directions.size());
  EXPECT_TRUE(r.converged);
  EXPECT_LT(transErr(r.transform, truth), 0.01);
  EXPECT_LT(rotErrDeg(r.transform, truth), 0.2);
  EXPECT_TRUE(r.degenerate_directions.empty());
}

// Reweighting steps on reused correspondences (correspondence_reuse_distance) save searches
// without moving the answer: the robust kernel's slow final crawl happens on fixed partners.
TEST(PropertyIcp, ReusedCorrespondencesSaveSearchesNotAccuracy) {
  const Pair p = roomPair(11, 0.01, 8000);
  for (const IcpMetric metric : {IcpMetric::PointToPlane, IcpMetric::PointToPoint}) {
    RegistrationConfig cfg;
    cfg.metric = metric;
    cfg.use_classes = false;  // with labelled points in play every step searches (next test)
    cfg.max_iterations = 150;
    cfg.correspondence_reuse_distance = 0.0;
    const auto every = registerPair(p, cfg);
    cfg.correspondence_reuse_distance = 0.05;
    const auto reuse = registerPair(p, cfg);
    ASSERT_TRUE(every.converged && reuse.converged) << every.reason << reuse.reason;
    EXPECT_LT(transErr(every.transform, reuse.transform), 0.002);
    EXPECT_LT(rotErrDeg(every.transform, reuse.transform), 0.02);
    EXPECT_LE(reuse.iterations, every.iterations);  // iterations = correspondence searches
    std::printf("%s: searches %d without reuse, %d with\n", toString(metric), every.iterations, reuse.iterations);
    if (metric == IcpMetric::PointToPlane) EXPECT_LT(reuse.iterations, every.iterations);
  }
  // Property ICP with labelled points: reuse is off, the result is the search-every-step one.
  RegistrationConfig cfg;
  cfg.correspondence_reuse_distance = 0.0;
  const auto every = registerPair(p, cfg);
  cfg.correspondence_reuse_distance = 0.05;
  const auto reuse = registerPair(p, cfg);
  ASSERT_GT(reuse.stats.property_points, 0u);
  EXPECT_TRUE(every.transform.matrix() == reuse.transform.matrix());
}

// Coarse to fine (coarse_source_points): the far-moving early steps on a strided subset, the
// answer from the full source — the same pose as a single full-source stage, in fewer searches of
// the full source; sources under 4× the subset run single-stage, bit for bit as with it off.
TEST(PropertyIcp, CoarseStageSavesFullSearchesNotAccuracy) {
  const Pair p = roomPair(12, 0.01, 8000);
  for (const bool classes : {false, true}) {
    RegistrationConfig cfg;
    cfg.use_classes = classes;
    cfg.max_iterations = 100;
    cfg.coarse_source_points = 0;
    const auto single = registerPair(p, cfg);
    cfg.coarse_source_points = 1000;
    const auto staged = registerPair(p, cfg);
    ASSERT_TRUE(single.converged && staged.converged) << single.reason << staged.reason;
    EXPECT_EQ(single.coarse_iterations, 0);
    EXPECT_GT(staged.coarse_iterations, 0);
    EXPECT_LT(staged.iterations, single.iterations);  // full-source searches
    EXPECT_LT(transErr(single.transform, staged.transform), 0.002);
    EXPECT_LT(rotErrDeg(single.transform, staged.transform), 0.02);
    EXPECT_LT(transErr(staged.transform, p.truth), 0.02);
    EXPECT_EQ(staged.stats.source_points, single.stats.source_points);  // the answer uses every point
    std::printf("%s: full-source searches %d single-stage, %d + %d coarse staged; poses %.2f mm apart\n",
                classes ? "property" : "plain", single.iterations, staged.iterations, staged.coarse_iterations,
                1e3 * transErr(single.transform, staged.transform));
    // Too small a source for the subset (needs 4×): single stage, the same bits.
    cfg.coarse_source_points = p.source.size() / 4 + 1;
    const auto small = registerPair(p, cfg);
    EXPECT_EQ(small.coarse_iterations, 0);
    EXPECT_TRUE(small.transform.matrix() == single.transform.matrix());
  }
}

TEST(PropertyIcp, PropertyPatchesFixTheCorridor) {
  // Plain ICP cannot tell where along the corridor it is; the labelled patches can.
  std::mt19937 rng(4);
  const auto scene = corridorScene(40.0, true);
  const Eigen::Isometry3d truth = fromXyzRpy(0.6, 0.0, 0.0, 0.0, 0.0, 0.0);
  const auto target = samplePatches(scene, 12000, rng, 0.01);
  const auto source = samplePatches(scene, 12000, rng, 0.01, truth.inverse());
  RegistrationConfig cfg;
  cfg.use_classes = false;
  const auto plain = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  cfg.use_classes = true;
  const auto prop = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  std::printf("corridor: plain ICP error %.3f m, property ICP error %.3f m\n",
              transErr(plain.transform, truth), transErr(prop.transform, truth));
  // Plain ICP slides: how far depends on the sampling, so only "much worse" and "knows it".
  EXPECT_GT(transErr(plain.transform, truth), 0.1);
  EXPECT_FALSE(plain.degenerate_directions.empty());
  EXPECT_LT(transErr(prop.transform, truth), 0.05);
  EXPECT_GT(prop.stats.property_matched, 0u);
}

TEST(PropertyIcp, LabelGateFallsBackToPlainOnRandomLabels) {
  // The same corridor with every label replaced by a random class: labels that do not agree with
  // the target's even after the labelled solve are noise, and the result is plain ICP's.
  std::mt19937 rng(4);
  const auto scene = corridorScene(40.0, true);
  const Eigen::Isometry3d truth = fromXyzRpy(0.3, 0.1, 0.0, 0.0, 0.0, 0.02);
  auto target = samplePatches(scene, 12000, rng, 0.01);
  auto source = samplePatches(scene, 12000, rng, 0.01, truth.inverse());
  std::uniform_int_distribution<int> cls(0, 3);
  for (auto& c : target.classes) c = static_cast<ClassId>(cls(rng));
  for (auto& c : source.classes) c = static_cast<ClassId>(cls(rng));
  RegistrationConfig cfg;
  cfg.use_classes = false;
  const auto plain = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  cfg.use_classes = true;
  const auto gated = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  EXPECT_FALSE(gated.labels_used);
  EXPECT_LT(std::abs(gated.label_agreement), 0.1);
  EXPECT_TRUE(gated.transform.isApprox(plain.transform, 1e-9));
  cfg.min_label_agreement = -1.0;  // gate off: the labels are used whatever they say
  const auto ungated = registerClouds(source, target, Eigen::Isometry3d::Identity(), ClassTable::defaults(), cfg);
  EXPECT_TRUE(ungated.labels_used);
  EXPECT_TRUE(std::isnan(ungated.label_agreement));
}

TEST(BadInput, DefinedResultsAndClearErrors) {
  const auto table = ClassTable::defaults();
  const Pair p = roomPair(1, 0.01, 4000);
  LabeledCloud empty;
  auto r = registerClouds(empty, p.target, Eigen::Isometry3d::Identity(), table);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reason, "empty source cloud");
  r = registerClouds(p.source, empty, Eigen::Isometry3d::Identity(), table);
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.reason, "empty target cloud");
  LabeledCloud tiny;
  tiny.push_back({1, 2, 3});
  r = registerClouds(tiny, p.target, Eigen::Isometry3d::Identity(), table);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.reason.find("min_correspondences"), std::string::npos);
  // far away: no correspondences at all
  r = registerClouds(p.source, p.target, fromXyzRpy(100, 0, 0, 0, 0, 0), table);
  EXPECT_FALSE(r.converged);
  EXPECT_NE(r.reason.find("correspondences"), std::string::npos);
  EXPECT_TRUE(r.transform.isApprox(fromXyzRpy(100, 0, 0, 0, 0, 0)));

  Eigen::Isometry3d nan_guess = Eigen::Isometry3d::Identity();
  nan_guess(0, 3) = NAN;
  EXPECT_THROW(registerClouds(p.source, p.target, nan_guess, table), Error);
  RegistrationConfig bad;
  bad.max_correspondence_distance = 0.0;
  EXPECT_THROW(registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(), table, bad), Error);
  bad = {};
  bad.max_correspondence_distance = -1.0;
  EXPECT_THROW(registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(), table, bad), Error);
  bad = {};
  bad.label_confidence = 0.0;
  EXPECT_THROW(registerClouds(p.source, p.target, Eigen::Isometry3d::Identity(), table, bad), Error);
  // a class missing from the table
  LabeledCloud odd = p.source;
  odd.classes[3] = 42;
  try {
    registerClouds(odd, p.target, Eigen::Isometry3d::Identity(), table);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("class 42"), std::string::npos) << e.what();
  }
  // plain ICP ignores classes, so an unknown class is fine there
  RegistrationConfig plain;
  plain.use_classes = false;
  EXPECT_NO_THROW(registerClouds(odd, p.target, Eigen::Isometry3d::Identity(), table, plain));
  // NaN points are skipped
  LabeledCloud with_nan = p.source;
  with_nan.points[0] = Eigen::Vector3f(NAN, 0, 0);
  r = registerClouds(with_nan, p.target, Eigen::Isometry3d::Identity(), table);
  EXPECT_TRUE(r.converged) << r.reason;
  // all points of one class
  LabeledCloud one_class_s = p.source, one_class_t = p.target;
  std::fill(one_class_s.classes.begin(), one_class_s.classes.end(), 1);
  std::fill(one_class_t.classes.begin(), one_class_t.classes.end(), 1);
  r = registerClouds(one_class_s, one_class_t, Eigen::Isometry3d::Identity(), table);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(transErr(r.transform, p.truth), 0.05);
  // preprocessing + registration: the same defined results and errors
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.1;
  r = registerScans(with_nan, p.target, Eigen::Isometry3d::Identity(), table, vd);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_EQ(registerScans(empty, p.target, Eigen::Isometry3d::Identity(), table, vd).reason, "empty source cloud");
  EXPECT_THROW(registerScans(odd, p.target, Eigen::Isometry3d::Identity(), table, vd), Error);
  EXPECT_THROW(registerScans(p.source, p.target, nan_guess, table, vd), Error);
  vd.voxel_size = 0.0;
  EXPECT_THROW(registerScans(p.source, p.target, Eigen::Isometry3d::Identity(), table, vd), Error);
}

TEST(RegistrationConfig, YamlRoundTripAndErrors) {
  RegistrationConfig c;
  c.metric = IcpMetric::PointToPoint;
  c.label_mode = LabelMode::Soft;
  c.max_correspondence_distance = 1.7;
  c.index = SpatialIndexKind::KdTree;
  const auto back = registrationConfigFromYaml(toYamlString(c), "test");
  EXPECT_EQ(back.metric, IcpMetric::PointToPoint);
  EXPECT_EQ(back.label_mode, LabelMode::Soft);
  EXPECT_EQ(back.index, SpatialIndexKind::KdTree);
  EXPECT_DOUBLE_EQ(back.max_correspondence_distance, 1.7);
  EXPECT_THROW(registrationConfigFromYaml("max_iterations: 0\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("bogus: 1\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("metric: triangle\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("property_tangent_weight: 1.5\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("min_label_agreement: 2\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("min_label_agreement: .nan\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("correspondence_reuse_distance: -0.1\n", "cfg.yaml"), Error);
  EXPECT_THROW(registrationConfigFromYaml("correspondence_reuse_distance: .nan\n", "cfg.yaml"), Error);
  c.correspondence_reuse_distance = 0.02;
  EXPECT_DOUBLE_EQ(registrationConfigFromYaml(toYamlString(c), "test").correspondence_reuse_distance, 0.02);
  EXPECT_THROW(registrationConfigFromYaml("coarse_source_points: 5\n", "cfg.yaml"), Error);  // < min_correspondences
  EXPECT_THROW(registrationConfigFromYaml("coarse_source_points: -1\n", "cfg.yaml"), Error);
  c.coarse_source_points = 0;
  EXPECT_EQ(registrationConfigFromYaml(toYamlString(c), "test").coarse_source_points, 0u);
  c.coarse_source_points = 750;
  EXPECT_EQ(registrationConfigFromYaml(toYamlString(c), "test").coarse_source_points, 750u);
  try {
    registrationConfigFromYaml("max_iterations: [1]\n", "cfg.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cfg.yaml"), std::string::npos);
  }
  const auto nested = registrationConfigFromYaml("registration:\n  max_iterations: 7\n", "x");
  EXPECT_EQ(nested.max_iterations, 7);
}
