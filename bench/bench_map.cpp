// Map assembly, hazard inventory, renders and map error.
//
//  - BM_GlobalMapLongRun: 10,000 frames driven down an endless corridor with the default voxel
//    cap; reports cells, coarsenings, the map's own bytes and the process's peak RSS growth —
//    the map stays bounded however long the run.
//  - BM_SaveMapRebuilt vs BM_SaveMapComposed: the map of a save while running, N frames into a
//    mission round a closed 20 m route after a loop correction moved every pose: rebuilt from
//    every scan at the corrected poses (what an autosave did, and the end still does) against
//    composed from segments built as the frames came (map/segmented_map.hpp: N / 100 segments,
//    none seen before, merged down to 8 and composed: a save's worst case). Rebuilding grows
//    with N; composing with the segments' cells, which the route's area bounds. (The corridor's
//    walls lie on the grid's planes: the rebuilt map keeps them one cell thick, segments built
//    in drifted frames put them up to a cell apart, so `cells` is larger composed.)
//  - BM_GlobalMapInsert vs BM_PclVoxelGridPeer: the same 100 VLP-16-like scans assembled into
//    a 0.1 m voxel map incrementally by GlobalMap (classes voted, frames recorded) and in one
//    batch by PCL's VoxelGrid over the concatenated cloud (no classes) — the peer.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include <sys/resource.h>

#include <cmath>
#include <random>

#include "hazmap/core/se3.hpp"
#include "hazmap/eval/map_error.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/render.hpp"
#include "hazmap/map/segmented_map.hpp"

#ifdef HAZMAP_BENCH_HAVE_PCL
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#endif

using namespace hazmap;

namespace {

long peakRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// A VLP-16-like scan (16 rings, ±15°, `azimuths` per ring) inside a corridor along x:
// walls at y = ±half_width, floor z = -0.5, ceiling z = 2.5 (sensor frame, sensor at origin).
// A heat patch sits on the left wall every 20 m of world x.
LabeledCloud corridorScan(int azimuths, double world_x, double half_width = 2.0) {
  LabeledCloud c;
  c.reserve(std::size_t(16 * azimuths));
  for (int r = 0; r < 16; ++r) {
    const double el = (-15.0 + 2.0 * r) * M_PI / 180.0;
    for (int a = 0; a < azimuths; ++a) {
      const double az = 2.0 * M_PI * a / azimuths;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
      double t = 30.0;
      if (std::abs(d.y()) > 1e-9) t = std::min(t, half_width / std::abs(d.y()));
      if (d.z() < -1e-9) t = std::min(t, 0.5 / -d.z());
      if (d.z() > 1e-9) t = std::min(t, 2.5 / d.z());
      if (t >= 30.0) continue;
      const Eigen::Vector3d p = d * t;
      ClassId cls = 0;
      const double wx = std::fmod(world_x + p.x() + 1e6, 20.0);
      if (p.y() > half_width - 1e-6 && wx < 1.0 && p.z() > 0.0 && p.z() < 1.0) cls = 1;
      c.push_back(p.cast<float>(), cls);
    }
  }
  return c;
}

void BM_GlobalMapLongRun(benchmark::State& state) {
  const int frames = int(state.range(0));
  for (auto _ : state) {
    const long rss_before = peakRssKb();
    GlobalMap map;  // defaults: 0.1 m voxels, 2,000,000-cell cap
    std::size_t peak_cells = 0, peak_bytes = 0;
    const LabeledCloud scan = corridorScan(450, 0.0);
    for (int f = 0; f < frames; ++f) {
      const double x = 0.5 * f;  // 0.5 m per frame: a 5 km corridor
      map.insert(std::size_t(f), scan, fromXyzRpy(x, 0, 0, 0, 0, 0));
      peak_cells = std::max(peak_cells, map.size());
      if (f % 500 == 0) peak_bytes = std::max(peak_bytes, map.memoryBytes());
    }
    peak_bytes = std::max(peak_bytes, map.memoryBytes());
    state.counters["frames"] = frames;
    state.counters["points_per_frame"] = double(scan.size());
    state.counters["cells"] = double(map.size());
    state.counters["peak_cells"] = double(peak_cells);
    state.counters["coarsenings"] = map.coarsenings();
    state.counters["final_voxel_m"] = map.voxelSize();
    state.counters["map_MB"] = double(peak_bytes) / 1e6;
    state.counters["peak_rss_growth_MB"] = double(peakRssKb() - rss_before) / 1e3;
    state.counters["peak_rss_MB"] = double(peakRssKb()) / 1e3;
    state.counters["frames_per_s"] = benchmark::Counter(double(frames), benchmark::Counter::kIsRate);
    benchmark::DoNotOptimize(map.size());
  }
}
BENCHMARK(BM_GlobalMapLongRun)->Arg(10000)->Iterations(1)->Unit(benchmark::kSecond);

std::vector<LabeledCloud> benchScans(int n) {
  std::vector<LabeledCloud> scans;
  for (int f = 0; f < n; ++f) scans.push_back(corridorScan(1800, 0.3 * f));
  return scans;
}

void BM_GlobalMapInsert(benchmark::State& state) {
  const auto scans = benchScans(int(state.range(0)));
  std::size_t points = 0, cells = 0;
  for (auto _ : state) {
    GlobalMapConfig cfg;
    cfg.voxel_size = 0.1;
    GlobalMap map(cfg);
    for (std::size_t f = 0; f < scans.size(); ++f) map.insert(f, scans[f], fromXyzRpy(0.3 * f, 0, 0, 0, 0, 0));
    points = map.pointsInserted();
    cells = map.size();
  }
  state.counters["cells"] = double(cells);
  state.counters["points_per_s"] = benchmark::Counter(double(points) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_GlobalMapInsert)->Arg(100)->Unit(benchmark::kMillisecond);

// A closed 20 m route along the corridor, 0.25 m a frame: 80 distinct scans, driven round again
// and again; the poses tracking gave (a slow yaw drift) and those after the loop correction.
struct ClosedRoute {
  std::vector<LabeledCloud> scans;
  ClosedRoute() {
    for (int k = 0; k < 80; ++k) scans.push_back(corridorScan(1800, 0.25 * k));
  }
  const LabeledCloud& scan(std::size_t f) const { return scans[f % 80]; }
  static Eigen::Isometry3d corrected(std::size_t f) { return fromXyzRpy(0.25 * double(f % 80), 0, 0, 0, 0, 0); }
  // Tracking's drift: a slow turn and sideways creep of the whole frame.
  static Eigen::Isometry3d tracked(std::size_t f) {
    return fromXyzRpy(0, 1e-4 * double(f), 0, 0, 0, 5e-6 * double(f)) * corrected(f);
  }
};

void BM_SaveMapRebuilt(benchmark::State& state) {
  static const ClosedRoute route;
  const std::size_t n = std::size_t(state.range(0));
  std::size_t cells = 0;
  for (auto _ : state) {
    GlobalMap map;
    for (std::size_t f = 0; f < n; ++f) map.insert(f, route.scan(f), ClosedRoute::corrected(f));
    cells = map.size();
  }
  state.counters["cells"] = double(cells);
}
BENCHMARK(BM_SaveMapRebuilt)->Arg(300)->Arg(1200)->Arg(4800)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_SaveMapComposed(benchmark::State& state) {
  static const ClosedRoute route;
  const std::size_t n = std::size_t(state.range(0));
  std::vector<Eigen::Isometry3d> tracked, corrected;
  for (std::size_t f = 0; f < n; ++f) tracked.push_back(ClosedRoute::tracked(f));
  for (std::size_t f = 0; f < n; ++f) corrected.push_back(ClosedRoute::corrected(f));
  std::size_t cells = 0, segments = 0;
  for (auto _ : state) {
    state.PauseTiming();  // the segments are built beside tracking, frame by frame
    SegmentedMap map(GlobalMapConfig{}, ClassTable::defaults());
    for (std::size_t f = 0; f < n; ++f) map.add(f, route.scan(f), {}, tracked, 100);
    map.close();
    state.ResumeTiming();
    cells = map.compose(n, corrected).size();  // n / 100 segments, merged down to 8 first
    segments = map.segments();
  }
  state.counters["cells"] = double(cells);
  state.counters["segments"] = double(segments);
}
BENCHMARK(BM_SaveMapComposed)->Arg(300)->Arg(1200)->Arg(4800)->Unit(benchmark::kMillisecond)->Iterations(2);

// Real scans: the six KITTI HDL-64 scans (labels where the sample has them) (~120k points each, dense near the car: several points
// per 0.1 m cell) at their reference poses, into a 0.1 m map with the semantic classes.
void BM_GlobalMapInsertKitti(benchmark::State& state) {
  const ClassTable table = ClassTable::semanticKitti();
  static const std::vector<LabeledCloud> scans = [&] {
    std::vector<LabeledCloud> out;
    const auto dir = std::filesystem::path(HAZMAP_SHARED_DATA_DIR) / "kitti-semantic-sample";
    for (int i = 0; i < 6; ++i) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d", i);
      const auto label = dir / "labels" / (std::string(name) + ".label");
      out.push_back(readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"),
                                  std::filesystem::exists(label) ? std::optional(label) : std::nullopt, table));
    }
    return out;
  }();
  std::size_t points = 0, cells = 0;
  for (auto _ : state) {
    GlobalMapConfig cfg;
    cfg.voxel_size = 0.1;
    GlobalMap map(cfg, table);
    for (std::size_t f = 0; f < scans.size(); ++f) map.insert(f, scans[f], fromXyzRpy(0.8 * double(f), 0, 0, 0, 0, 0));
    points = map.pointsInserted();
    cells = map.size();
  }
  state.counters["cells"] = double(cells);
  state.counters["points_per_s"] = benchmark::Counter(double(points) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_GlobalMapInsertKitti)->Unit(benchmark::kMillisecond);

#ifdef HAZMAP_BENCH_HAVE_PCL
void BM_PclVoxelGridPeer(benchmark::State& state) {
  const auto scans = benchScans(int(state.range(0)));
  std::size_t points = 0, cells = 0;
  for (auto _ : state) {
    // The same work as GlobalMap minus classes/frames: place every scan, then one voxel grid.
    pcl::PointCloud<pcl::PointXYZ>::Ptr all(new pcl::PointCloud<pcl::PointXYZ>);
    for (std::size_t f = 0; f < scans.size(); ++f) {
      const Eigen::Isometry3f T = fromXyzRpy(0.3 * f, 0, 0, 0, 0, 0).cast<float>();
      for (const auto& p : scans[f].points) {
        const Eigen::Vector3f q = T * p;
        all->push_back(pcl::PointXYZ(q.x(), q.y(), q.z()));
      }
    }
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setInputCloud(all);
    grid.setLeafSize(0.1f, 0.1f, 0.1f);
    pcl::PointCloud<pcl::PointXYZ> out;
    grid.filter(out);
    points = all->size();
    cells = out.size();
  }
  state.counters["cells"] = double(cells);
  state.counters["points_per_s"] = benchmark::Counter(double(points) * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_PclVoxelGridPeer)->Arg(100)->Unit(benchmark::kMillisecond);
#endif

void BM_FindHazardsAndRender(benchmark::State& state) {
  GlobalMap map;
  for (int f = 0; f < 200; ++f)
    map.insert(std::size_t(f), corridorScan(1800, 0.5 * f), fromXyzRpy(0.5 * f, 0, 0, 0, 0, 0));
  const LabeledCloud cloud = map.cloud();
  std::vector<Eigen::Vector3d> traj;
  for (int f = 0; f < 200; ++f) traj.emplace_back(0.5 * f, 0, 0);
  std::size_t hazards = 0;
  for (auto _ : state) {
    const auto h = findHazards(map);
    TopDownConfig cfg;
    cfg.cell_size = map.voxelSize();
    const Image img = renderTopDown(cloud, map.classTable(), traj, h, cfg);
    benchmark::DoNotOptimize(encodePng(img).size());
    hazards = h.size();
  }
  state.counters["cells"] = double(map.size());
  state.counters["hazards"] = double(hazards);
}
BENCHMARK(BM_FindHazardsAndRender)->Unit(benchmark::kMillisecond);

void BM_MapError(benchmark::State& state) {
  const auto scans = benchScans(200);
  Trajectory truth, est;
  for (int f = 0; f < 200; ++f) {
    truth.push_back(f, fromXyzRpy(0.3 * f, 0, 0, 0, 0, 0));
    est.push_back(f, fromXyzRpy(0.3 * f + 0.001 * f, 0.0005 * f, 0, 0, 0, 0.0002 * f));
  }
  MapErrorConfig cfg;
  cfg.cloud_to_cloud = state.range(0) != 0;
  double mean = 0;
  for (auto _ : state) mean = computeMapError(scans, est, truth, cfg).point.mean;
  state.counters["map_error_m"] = mean;
  state.counters["frames_per_s"] = benchmark::Counter(200.0 * state.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_MapError)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
