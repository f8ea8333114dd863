// Loop-closure benchmarks: landmark extraction on a VLP-16-sized scan (peer: PCL's
// EuclideanClusterExtraction on the same labelled points, same tolerance), and the constellation
// candidate search of one query against a few hundred keyframes. BM_ConsistentSubset: the
// pairwise loop-consistency check the back end runs before each optimisation, L loops over a
// closed route of 3,000 keyframes (a long mission), against its pairs computed one by one with
// pairwiseDistance2 (each summing the path between the keyframes: what it did before
// 2026-12-05, when that sum was 43 % of a long icp+pgo live session's CPU).
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <random>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/loop/candidates.hpp"
#include "hazmap/loop/consistency.hpp"
#include "hazmap/loop/landmarks.hpp"

#ifdef HAZMAP_BENCH_HAVE_PCL
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>
#endif

namespace {

using namespace hazmap;

// ~29k points like one VLP-16 scan: unlabelled clutter plus six property patches (heat on walls,
// water on the floor) of a few hundred to a few thousand points, and 0.5 % label noise.
LabeledCloud scanLikeCloud() {
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  LabeledCloud c;
  c.reserve(30000);
  for (int i = 0; i < 27000; ++i) {
    const float r = 2.f + 20.f * (0.5f + 0.5f * u(rng)), a = 3.14159f * u(rng);
    c.push_back({r * std::cos(a), r * std::sin(a), 0.5f * u(rng)}, (i % 200 == 0) ? 1 : 0);
  }
  const Eigen::Vector3f centers[] = {{5, 2, 0.5}, {-6, 4, 1}, {10, -7, -0.5}, {-3, -9, -0.5}, {15, 9, 1}, {2, 12, 0}};
  for (int k = 0; k < 6; ++k)
    for (int i = 0; i < 300 + 120 * k; ++i)
      c.push_back(centers[k] + Eigen::Vector3f(u(rng), u(rng), 0.3f * u(rng)), k % 2 ? 2 : 1);
  return c;
}

void BM_ExtractLandmarks(benchmark::State& state) {
  const LabeledCloud cloud = scanLikeCloud();
  const ClassTable table = ClassTable::defaults();
  LandmarkConfig cfg;
  cfg.max_range = 0;
  std::size_t n = 0;
  for (auto _ : state) {
    auto lms = extractLandmarks(cloud, table, cfg);
    n = lms.size();
    benchmark::DoNotOptimize(lms);
  }
  state.counters["landmarks"] = static_cast<double>(n);
}
BENCHMARK(BM_ExtractLandmarks)->Unit(benchmark::kMicrosecond);

#ifdef HAZMAP_BENCH_HAVE_PCL
// The peer: one PCL Euclidean clustering per property class over the same labelled points
// (building the per-class clouds is included, as hazmap's time includes its selection).
void BM_PclEuclideanClusters(benchmark::State& state) {
  const LabeledCloud cloud = scanLikeCloud();
  const LandmarkConfig cfg;
  std::size_t n = 0;
  for (auto _ : state) {
    n = 0;
    for (ClassId cls : {ClassId{1}, ClassId{2}}) {
      pcl::PointCloud<pcl::PointXYZ>::Ptr pc(new pcl::PointCloud<pcl::PointXYZ>);
      for (std::size_t i = 0; i < cloud.size(); ++i)
        if (cloud.classes[i] == cls) pc->push_back({cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z()});
      pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
      tree->setInputCloud(pc);
      std::vector<pcl::PointIndices> clusters;
      pcl::EuclideanClusterExtraction<pcl::PointXYZ> ec;
      ec.setClusterTolerance(cfg.cluster_tolerance);
      ec.setMinClusterSize(static_cast<int>(cfg.min_points));
      ec.setSearchMethod(tree);
      ec.setInputCloud(pc);
      ec.extract(clusters);
      n += clusters.size();
    }
    benchmark::DoNotOptimize(n);
  }
  state.counters["landmarks"] = static_cast<double>(n);
}
BENCHMARK(BM_PclEuclideanClusters)->Unit(benchmark::kMicrosecond);
#endif

// One query against `range(0)` past keyframes, each seeing 4–7 of 12 sources.
void BM_ConstellationSearch(benchmark::State& state) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<PropertyLandmark> world;
  for (int k = 0; k < 12; ++k) {
    PropertyLandmark l;
    l.class_id = static_cast<ClassId>(1 + k % 2);
    l.centroid = {20 * u(rng), 12 * u(rng), 0.5 * u(rng)};
    l.extent = {0.5, 0.3, 0.05};
    world.push_back(l);
  }
  const std::size_t frames = static_cast<std::size_t>(state.range(0));
  std::vector<std::vector<PropertyLandmark>> lms(frames + 1);
  for (auto& f : lms) {
    const Eigen::Isometry3d T = fromXyYaw(10 * u(rng), 6 * u(rng), 3 * u(rng));
    for (const auto& l : world) {
      if (u(rng) < -0.3) continue;
      PropertyLandmark s = l;
      s.centroid = T * l.centroid + 0.1 * Eigen::Vector3d(u(rng), u(rng), u(rng));
      f.push_back(s);
    }
  }
  CandidateSearchConfig cfg;
  std::size_t found = 0;
  for (auto _ : state) {
    auto c = findConstellationCandidates(frames, lms, cfg);
    found = c.size();
    benchmark::DoNotOptimize(c);
  }
  state.counters["candidates"] = static_cast<double>(found);
  state.counters["keyframes/s"] = benchmark::Counter(static_cast<double>(frames) * state.iterations(),
                                                     benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ConstellationSearch)->Arg(150)->Arg(600)->Unit(benchmark::kMillisecond);

}  // namespace

namespace {

// A 100 m closed route driven three times (3,000 keyframes, 0.1 m apart) and `n` loops between
// the laps, all right.
struct LoopsOnLaps {
  PoseList poses;
  std::vector<LoopClosure> loops;
  explicit LoopsOnLaps(std::size_t n) {
    for (std::size_t k = 0; k < 3000; ++k) {
      const double s = 0.1 * double(k % 1000), angle = 2 * M_PI * s / 100.0;
      poses.push_back(fromXyzRpy(15.9 * std::cos(angle), 15.9 * std::sin(angle), 0, 0, 0, angle + M_PI / 2));
    }
    for (std::size_t i = 0; i < n; ++i) {
      LoopClosure l;
      l.from = (i * 37) % 1000;
      l.to = l.from + 1000 * (1 + i % 2);
      l.T_from_to = poses[l.from].inverse() * poses[l.to];
      l.covariance = Matrix6d::Identity() * 1e-4;
      loops.push_back(l);
    }
  }
};

void BM_ConsistentSubset(benchmark::State& state) {
  const LoopsOnLaps route(std::size_t(state.range(0)));
  std::size_t kept = 0;
  for (auto _ : state) kept = consistentSubset(route.loops, route.poses).size();
  state.counters["kept"] = double(kept);
}
BENCHMARK(BM_ConsistentSubset)->Arg(100)->Arg(400)->Arg(1600)->Unit(benchmark::kMillisecond);

// The back end's pattern on a long mission: the consistent loops asked for again after one more
// loop (here: the newest forgotten, then accepted again: two calls per iteration), the pairs
// already tested remembered. Against BM_ConsistentSubset at the same count, one call from scratch.
void BM_IncrementalConsistencyOneMoreLoop(benchmark::State& state) {
  const LoopsOnLaps route(std::size_t(state.range(0)));
  IncrementalConsistency consistency;
  std::vector<LoopClosure> fewer(route.loops.begin(), route.loops.end() - 1);
  std::size_t kept = consistency.subset(route.loops, route.poses).size();
  for (auto _ : state) {
    benchmark::DoNotOptimize(consistency.subset(fewer, route.poses));
    kept = consistency.subset(route.loops, route.poses).size();
  }
  state.counters["kept"] = double(kept);
}
BENCHMARK(BM_IncrementalConsistencyOneMoreLoop)->Arg(100)->Arg(400)->Arg(1600)->Unit(benchmark::kMillisecond);

void BM_ConsistencyPairsSummedAlongThePath(benchmark::State& state) {
  const LoopsOnLaps route(std::size_t(state.range(0)));
  const double threshold = chiSquareQuantile(6, ConsistencyConfig{}.gate_probability);
  std::size_t consistent = 0;
  for (auto _ : state) {
    consistent = 0;
    for (std::size_t i = 0; i < route.loops.size(); ++i)
      for (std::size_t j = i + 1; j < route.loops.size(); ++j)
        consistent += pairwiseDistance2(route.loops[i], route.loops[j], route.poses) <= threshold;
  }
  state.counters["consistent_pairs"] = double(consistent);
}
BENCHMARK(BM_ConsistencyPairsSummedAlongThePath)->Arg(100)->Arg(400)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
