// Preprocessing used by the odometry's fast path: the fused crop + voxel downsample against the
// two-step reference, thread-count independence, and the local map's cached normals against the
// normals a freshly built registration target estimates.
#include <gtest/gtest.h>

#include <limits>
#include <tbb/global_control.h>

#include <array>
#include <cstdio>
#include <map>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/preprocess/crop.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

void expectSameCloud(const LabeledCloud& a, const LabeledCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.hasIntensity(), b.hasIntensity());
  ASSERT_EQ(a.hasProperty(), b.hasProperty());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.points[i], b.points[i]) << i;
    ASSERT_EQ(a.classes[i], b.classes[i]) << i;
    if (a.hasIntensity()) ASSERT_EQ(a.intensity[i], b.intensity[i]) << i;
    if (a.hasProperty()) ASSERT_EQ(a.property[i], b.property[i]) << i;
  }
}

}  // namespace

TEST(Preprocess, CropAndDownsampleEqualsTheTwoSteps) {
  const ClassTable table = ClassTable::semanticKitti();
  const LabeledCloud scan = test::kittiScan(0, table);
  RangeCropConfig crop;
  crop.min_range = 3.0;
  crop.max_range = 40.0;
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  vd.vote = ClassVote::PreferProperty;
  const LabeledCloud fused = cropAndDownsample(scan, crop, vd, table);
  const LabeledCloud reference = voxelDownsample(cropRange(scan, crop), vd, table);
  EXPECT_GT(fused.size(), 5000u);
  EXPECT_LT(fused.size(), scan.size() / 4);
  expectSameCloud(fused, reference);
  // every point inside the range (a centroid of in-range points stays within the outer bound)
  for (const auto& p : fused.points) EXPECT_LE(p.norm(), 40.0f + 1e-3f);
  // property classes survive the vote
  std::size_t props = 0;
  for (ClassId c : fused.classes) props += table.isProperty(c);
  EXPECT_GT(props, 10u);
}

TEST(Preprocess, DownsampleDoesNotDependOnThreads) {
  const ClassTable table = ClassTable::semanticKitti();
  const LabeledCloud scan = test::kittiScan(1, table);
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.3;
  vd.vote = ClassVote::PreferProperty;
  LabeledCloud one, two;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = voxelDownsample(scan, vd, table);
  }
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
    two = voxelDownsample(scan, vd, table);
  }
  expectSameCloud(one, two);
}

TEST(Preprocess, CropAndDownsampleRejectsBadConfig) {
  LabeledCloud c;
  c.push_back({1, 2, 3});
  RangeCropConfig crop;
  crop.min_range = 5.0;
  crop.max_range = 2.0;
  EXPECT_THROW(cropAndDownsample(c, crop, {}), Error);
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.0;
  EXPECT_THROW(cropAndDownsample(c, RangeCropConfig{}, vd), Error);
  // NaN points and an empty cloud are fine
  c.push_back({std::nanf(""), 0, 0});
  EXPECT_EQ(cropAndDownsample(c, RangeCropConfig{}, VoxelDownsampleConfig{}).size(), 1u);
  c.push_back({0, std::numeric_limits<float>::infinity(), 0});
  const LabeledCloud kept = voxelDownsample(c, VoxelDownsampleConfig{});  // non-finite dropped
  ASSERT_EQ(kept.size(), 1u);
  EXPECT_TRUE(kept.points[0] == Eigen::Vector3f(1, 2, 3));
  EXPECT_TRUE(cropAndDownsample(LabeledCloud{}, RangeCropConfig{}, VoxelDownsampleConfig{}).empty());
}

// The local map's normals come from its own voxels; on a fresh map they must equal what a
// registration target built from the same cloud estimates with its k-d/voxel index.
TEST(LocalMapNormals, FreshMapMatchesTheTargetsOwnEstimate) {
  const ClassTable table = ClassTable::semanticKitti();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  vd.vote = ClassVote::PreferProperty;
  const LabeledCloud scan = voxelDownsample(test::kittiScan(0, table), vd, table);
  LocalMap map(LocalMapConfig{});
  map.integrate(scan, Eigen::Vector3d::Zero(), table);
  RegistrationConfig rc;
  const RegistrationTarget cached = map.makeTarget(table, rc);
  const RegistrationTarget fresh(map.cloud(), table, rc);
  ASSERT_EQ(cached.size(), fresh.size());
  ASSERT_EQ(cached.normals().size(), fresh.normals().size());
  std::size_t same = 0, with_normal = 0;
  for (std::size_t i = 0; i < cached.size(); ++i) {
    ASSERT_EQ(cached.cloud().points[i], fresh.cloud().points[i]);
    const Eigen::Vector3f a = cached.normals()[i], b = fresh.normals()[i];
    with_normal += !b.isZero();
    same += (a.isZero() && b.isZero()) || (!a.isZero() && !b.isZero() && std::abs(a.dot(b)) > 0.9999f);
  }
  EXPECT_GT(with_normal, cached.size() / 2);
  // identical up to ties among equidistant neighbours
  EXPECT_GE(same, cached.size() - cached.size() / 1000);
  // and both targets give the same correspondences
  for (std::size_t i = 0; i < scan.size(); i += 37) {
    const Eigen::Vector3f q = scan.points[i] + Eigen::Vector3f(0.1f, -0.05f, 0.02f);
    const TargetMatch m1 = cached.match(q, scan.classes[i], 0.0f), m2 = fresh.match(q, scan.classes[i], 0.0f);
    EXPECT_EQ(m1.index, m2.index);
  }
}

// After more scans arrive (and the robot moves so that far voxels are dropped), the cached normals
// still equal a from-scratch estimate: the change tracking (k-th neighbour reach, dropped voxels)
// misses nothing. Results do not
// depend on the thread count.
// Points whose normal differs between the map's cached target and a fresh one (both zero, or the
// same line within 0.8°, count as equal); every point when the sizes differ.
static std::size_t normalsDiffering(const RegistrationTarget& cached, const RegistrationTarget& fresh) {
  if (cached.normals().size() != fresh.normals().size()) return std::max<std::size_t>(cached.size(), 1);
  std::size_t same = 0;
  for (std::size_t k = 0; k < cached.size(); ++k) {
    const Eigen::Vector3f a = cached.normals()[k], b = fresh.normals()[k];
    same += (a.isZero() && b.isZero()) || (!a.isZero() && !b.isZero() && std::abs(a.dot(b)) > 0.9999f);
  }
  return cached.size() - same;
}

TEST(LocalMapNormals, CachedAcrossFramesEqualsFreshAndThreadIndependent) {
  const ClassTable table = ClassTable::semanticKitti();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  vd.vote = ClassVote::PreferProperty;
  std::vector<LabeledCloud> scans;
  for (int i = 0; i < 3; ++i) scans.push_back(voxelDownsample(test::kittiScan(i, table), vd, table));
  RegistrationConfig rc;
  LocalMapConfig mc;
  mc.max_distance = 30.0;  // small, so that voxels are dropped as the origin moves
  std::vector<std::vector<Eigen::Vector3f>> runs;
  for (int threads : {1, 2}) {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, threads);
    LocalMap map(mc);
    std::vector<Eigen::Vector3f> last;
    for (int i = 0; i < 3; ++i) {
      // the scans are close together; shift each a little so new points land between old ones
      const Eigen::Isometry3d T(Eigen::Translation3d(0.8 * i, 0.1 * i, 0.0));
      map.integrate(scans[i].transformed(T), T.translation() + Eigen::Vector3d(3.0 * i, 0, 0), table);
      const RegistrationTarget cached = map.makeTarget(table, rc);
      const RegistrationTarget fresh(map.cloud(), table, rc);
      // exact up to ties among equidistant neighbours (none occurred on these scans)
      EXPECT_LE(normalsDiffering(cached, fresh), cached.size() / 10000) << "frame " << i;
      last = cached.normals();
    }
    runs.push_back(last);
  }
  EXPECT_EQ(runs[0], runs[1]);
}

// Voxels dropped, moved (the map swap-removes) and added back frame after frame, the robot driving
// to and fro past the map's bound: every cached normal stays the one a fresh estimate gives, so
// no voxel misses the change of a neighbour (the map keeps each voxel's neighbours as a table).
TEST(LocalMapNormals, CachedNormalsSurviveVoxelsDroppedAndAddedBack) {
  const ClassTable table = ClassTable::semanticKitti();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  const LabeledCloud scan = voxelDownsample(test::kittiScan(0, table), vd, table);
  RegistrationConfig rc;
  LocalMapConfig mc;
  mc.max_distance = 12.0;
  LocalMap map(mc);
  const double xs[] = {0.0, 9.0, 18.0, 9.0, 0.0, -9.0, 4.5, 13.5};
  for (int i = 0; i < 8; ++i) {
    const Eigen::Isometry3d T(Eigen::Translation3d(0.3 * i, 0.2 * (i % 3), 0.0));
    const std::size_t before = map.voxels();
    map.integrate(scan.transformed(T), Eigen::Vector3d(xs[i], 0, 0), table);
    const RegistrationTarget cached = map.makeTarget(table, rc);
    const RegistrationTarget fresh(map.cloud(), table, rc);
    EXPECT_LE(normalsDiffering(cached, fresh), cached.size() / 10000)
        << "frame " << i << ", voxels " << before << " -> " << map.voxels();
  }
}

// Lazy normals (what the odometry uses): between frames only some points' normals are asked for,
// as ICP pairs them; whenever one is asked for, and at the end for all, it equals the eager map's.
TEST(LocalMapNormals, LazyNormalsEqualEagerOnes) {
  const ClassTable table = ClassTable::semanticKitti();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  std::vector<LabeledCloud> scans;
  for (int i = 0; i < 3; ++i) scans.push_back(voxelDownsample(test::kittiScan(i, table), vd, table));
  RegistrationConfig rc;
  LocalMapConfig mc;
  mc.max_distance = 30.0;
  LocalMap eager(mc), lazy(mc);
  for (int i = 0; i < 3; ++i) {
    const Eigen::Isometry3d T(Eigen::Translation3d(0.8 * i, 0.1 * i, 0.0));
    const Eigen::Vector3d origin = T.translation() + Eigen::Vector3d(3.0 * i, 0, 0);
    eager.integrate(scans[i].transformed(T), origin, table);
    lazy.integrate(scans[i].transformed(T), origin, table);
    const RegistrationTarget e = eager.makeTarget(table, rc);
    const RegistrationTarget l = lazy.makeTarget(table, rc, /*lazy_normals=*/true);
    ASSERT_EQ(e.size(), l.size());
    std::size_t asked = 0, differ = 0;
    for (std::size_t j = 0; j < l.size(); j += (i == 2 ? 1 : 7)) {  // a subset, then all
      ++asked;
      differ += l.normal(j) != e.normals()[j];
    }
    EXPECT_EQ(differ, 0u) << "frame " << i << ", " << asked << " normals asked";
  }
}

// With a re-estimation budget of one, a point keeps the normal it first got.
TEST(LocalMapNormals, BudgetFreezesNormals) {
  const ClassTable table = ClassTable::semanticKitti();
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.5;
  const LabeledCloud s0 = voxelDownsample(test::kittiScan(0, table), vd, table);
  const LabeledCloud s1 = voxelDownsample(test::kittiScan(1, table), vd, table);
  LocalMapConfig mc;
  mc.normal_updates = 1;
  LocalMap map(mc);
  RegistrationConfig rc;
  map.integrate(s0, Eigen::Vector3d::Zero(), table);
  const RegistrationTarget t0 = map.makeTarget(table, rc);
  map.integrate(s1.transformed(Eigen::Isometry3d(Eigen::Translation3d(0.3, 0.2, 0.0))), Eigen::Vector3d::Zero(), table);
  const RegistrationTarget t1 = map.makeTarget(table, rc);
  const RegistrationTarget fresh(map.cloud(), table, rc);
  // find each of t0's points in t1 (a voxel's new points follow its old ones, so indices shift)
  std::map<std::array<float, 3>, std::size_t> at;
  for (std::size_t j = 0; j < t1.size(); ++j) {
    const auto& p = t1.cloud().points[j];
    at[{p.x(), p.y(), p.z()}] = j;
  }
  std::size_t had = 0, kept = 0, differs_from_fresh = 0, replaced = 0;
  for (std::size_t i = 0; i < t0.size(); ++i) {
    const auto& p = t0.cloud().points[i];
    const auto it = at.find({p.x(), p.y(), p.z()});
    if (it == at.end()) {  // a property point replaced it in a full voxel
      ++replaced;
      continue;
    }
    const std::size_t j = it->second;
    if (t0.normals()[i].isZero()) continue;
    ++had;
    kept += t1.normals()[j] == t0.normals()[i];
    differs_from_fresh += t1.normals()[j] != fresh.normals()[j];
  }
  EXPECT_GT(had, t0.size() / 2);
  EXPECT_LT(replaced, t0.size() / 100);
  EXPECT_EQ(kept, had);
  EXPECT_GT(differs_from_fresh, had / 10);  // the exact default would have re-estimated these
  LocalMapConfig bad;
  bad.normal_updates = -1;
  EXPECT_THROW(bad.validate(), Error);
}
