// Tracking's preprocessing (crop + voxel downsampling with the property vote, odometry defaults)
// on real scans: a KITTI HDL-64 scan (~120k points) and an Ouster OS-1-128 scan (~130k), one and
// two threads. The peer in the same run: a plain first-point-per-voxel downsample of the same
// scan at the same voxel (what KISS-ICP does: no centroid, no vote), std::unordered_map, one
// thread. Counters: points_in, points_out, and Mpoints/s.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include <tbb/global_control.h>

#include <cmath>
#include <optional>
#include <unordered_map>

#include "hazmap/core/voxel_key.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/sources/scan_source.hpp"

using namespace hazmap;

namespace {

const std::filesystem::path kData = HAZMAP_SHARED_DATA_DIR;

const LabeledCloud& scanOf(int which) {
  static const LabeledCloud kitti = [] {
    const auto dir = kData / "kitti-semantic-sample";
    return readKittiScan(dir / "velodyne" / "000000.bin", dir / "labels" / "000000.label", ClassTable::semanticKitti());
  }();
  static const LabeledCloud ouster = [] {
    auto src = openScanSource(kData / "sensors" / "ouster-os1-128" / "OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
    return src->next().value().cloud;
  }();
  return which == 0 ? kitti : ouster;
}

const ClassTable& tableOf(int which) {
  static const ClassTable kitti = ClassTable::semanticKitti(), plain = ClassTable::defaults();
  return which == 0 ? kitti : plain;
}

void BM_TrackingPreprocess(benchmark::State& state) {
  const LabeledCloud& scan = scanOf(static_cast<int>(state.range(0)));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(state.range(1)));
  const OdometryConfig config;
  std::size_t out = 0;
  for (auto _ : state) {
    const LabeledCloud c = preprocessForTracking(scan, config, tableOf(static_cast<int>(state.range(0))));
    out = c.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  state.counters["points_in"] = static_cast<double>(scan.size());
  state.counters["points_out"] = static_cast<double>(out);
  state.counters["Mpoints_per_s"] = benchmark::Counter(static_cast<double>(scan.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

// The peer: the first point of each voxel kept, within the same range crop (KISS-ICP's way).
void BM_FirstPointPerVoxel(benchmark::State& state) {
  const LabeledCloud& scan = scanOf(static_cast<int>(state.range(0)));
  const OdometryConfig config;
  const double inv = 1.0 / config.voxel_size, lo2 = config.min_range * config.min_range,
               hi2 = config.max_range * config.max_range;
  std::size_t out = 0;
  for (auto _ : state) {
    std::unordered_map<std::uint64_t, std::uint32_t> first;
    first.reserve(scan.size() / 4);
    std::vector<Eigen::Vector3f> kept;
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const Eigen::Vector3f& p = scan.points[i];
      const double r2 = p.cast<double>().squaredNorm();
      if (!p.allFinite() || r2 < lo2 || r2 > hi2) continue;
      std::array<std::int64_t, 3> c;
      std::uint64_t key = 0;
      voxelOfPoint(p.x() * inv, p.y() * inv, p.z() * inv, c, key);
      if (first.emplace(key, static_cast<std::uint32_t>(i)).second) kept.push_back(p);
    }
    out = kept.size();
    benchmark::DoNotOptimize(kept.data());
  }
  state.counters["points_in"] = static_cast<double>(scan.size());
  state.counters["points_out"] = static_cast<double>(out);
  state.counters["Mpoints_per_s"] = benchmark::Counter(static_cast<double>(scan.size()) * 1e-6, benchmark::Counter::kIsIterationInvariantRate);
}

BENCHMARK(BM_TrackingPreprocess)->ArgsProduct({{0, 1}, {1, 2}})->ArgNames({"scan", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FirstPointPerVoxel)->ArgsProduct({{0, 1}})->ArgNames({"scan"})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

HAZMAP_BENCHMARK_MAIN()
