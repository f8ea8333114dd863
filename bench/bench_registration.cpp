// Registration speed and accuracy: hazmap plain / property ICP against PCL (ICP, GICP) and
// Open3D (point-to-point, point-to-plane, GICP) in one run, same raw inputs, same initial guess
// (identity), each library doing its own voxel downsampling (0.25 m scan pair, 0.5 m KITTI) and
// normals/covariances: "preprocessing + registration" per iteration, max correspondence 1.0 m.
// Counters: iterations, error vs the reference (cm, deg). Arg = threads (PCL is single-threaded).
// Every pair row warms up for 0.3 s first: without it the first row of the run paid for cold caches
// and the thread pool (property ICP measured 4 ms slower than plain ICP in the full run, equal
// alone).
// Also: frame-to-map odometry on the six KITTI scans (ms per frame) and on 60 simulated VLP-16
// frames of the naraha scenario (frames/s).
#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <optional>

#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/transform_file.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/sim/simulator.hpp"

#ifdef HAZMAP_BENCH_HAVE_PCL
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>
#endif
#ifdef HAZMAP_BENCH_HAVE_OPEN3D
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/pipelines/registration/GeneralizedICP.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>
extern "C" void omp_set_num_threads(int);
#endif

using namespace hazmap;

namespace {

const std::filesystem::path kData = HAZMAP_SHARED_DATA_DIR;

struct PairData {
  LabeledCloud source, target;
  Eigen::Isometry3d reference = Eigen::Isometry3d::Identity();
  double voxel = 0.25;
};

const PairData& scanPair() {
  static const PairData d = [] {
    PairData p;
    p.target = readPcd(kData / "scan-pair/251370668.pcd");
    p.source = readPcd(kData / "scan-pair/251371071.pcd");
    p.reference = readTransformFile(kData / "scan-pair/relative.txt");
    p.voxel = 0.25;
    return p;
  }();
  return d;
}

LabeledCloud kittiScan(int i, const ClassTable& table) {
  char name[32];
  std::snprintf(name, sizeof name, "%06d", i);
  const auto dir = kData / "kitti-semantic-sample";
  const auto label = dir / "labels" / (std::string(name) + ".label");
  return readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"),
                       std::filesystem::exists(label) ? std::optional(label) : std::nullopt, table);
}

const PairData& kittiPair() {
  static const PairData d = [] {
    PairData p;
    const ClassTable table = ClassTable::semanticKitti();
    p.target = kittiScan(0, table);
    p.source = kittiScan(1, table);
    // No ground truth for these scans (see the data README): the reference is hazmap's own
    // converged point-to-plane result at 0.25 m, used only to compare the peers' answers.
    VoxelDownsampleConfig vd;
    vd.voxel_size = 0.25;
    RegistrationConfig cfg;
    cfg.use_classes = false;
    cfg.max_iterations = 100;
    cfg.translation_tolerance = cfg.rotation_tolerance = 1e-6;
    p.reference = registerClouds(voxelDownsample(p.source, vd), voxelDownsample(p.target, vd),
                                 Eigen::Isometry3d::Identity(), table, cfg)
                      .transform;
    p.voxel = 0.5;
    return p;
  }();
  return d;
}

void report(benchmark::State& state, const Eigen::Isometry3d& T, const Eigen::Isometry3d& ref, int iterations) {
  const Eigen::Isometry3d e = ref.inverse() * T;
  state.counters["err_cm"] = e.translation().norm() * 100.0;
  state.counters["err_deg"] = rotationAngle(e) * 180.0 / M_PI;
  state.counters["iters"] = iterations;
}

// `overlapped` = registerScans (the source's downsampling alongside the target's preparation);
// false = the two downsamplings one after the other, then registerClouds (same answer).
void hazmapIcp(benchmark::State& state, const PairData& d, bool classes, IcpMetric metric,
               bool overlapped = true) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(0));
  const ClassTable table = ClassTable::semanticKitti();
  const VoxelDownsampleConfig vd = propertyVoxels(d.voxel);
  RegistrationConfig cfg;
  cfg.use_classes = classes;
  cfg.metric = metric;
  RegistrationResult r;
  for (auto _ : state) {
    if (overlapped) {
      r = registerScans(d.source, d.target, Eigen::Isometry3d::Identity(), table, vd, cfg);
    } else {
      const LabeledCloud s = voxelDownsample(d.source, vd, table);
      const LabeledCloud t = voxelDownsample(d.target, vd, table);
      r = registerClouds(s, t, Eigen::Isometry3d::Identity(), table, cfg);
    }
    benchmark::DoNotOptimize(r.transform);
  }
  report(state, r.transform, d.reference, r.iterations);
  state.counters["coarse_iters"] = r.coarse_iterations;
}

void BM_ScanPair_Hazmap_PropertyIcp_Plane(benchmark::State& s) { hazmapIcp(s, scanPair(), true, IcpMetric::PointToPlane); }
void BM_ScanPair_Hazmap_PropertyIcp_Point(benchmark::State& s) { hazmapIcp(s, scanPair(), true, IcpMetric::PointToPoint); }
void BM_ScanPair_Hazmap_Icp_Plane(benchmark::State& s) { hazmapIcp(s, scanPair(), false, IcpMetric::PointToPlane); }
void BM_ScanPair_Hazmap_Icp_Point(benchmark::State& s) { hazmapIcp(s, scanPair(), false, IcpMetric::PointToPoint); }
void BM_ScanPair_Hazmap_PropertyIcp_Plane_Sequential(benchmark::State& s) {
  hazmapIcp(s, scanPair(), true, IcpMetric::PointToPlane, false);
}
void BM_Kitti_Hazmap_PropertyIcp_Plane(benchmark::State& s) { hazmapIcp(s, kittiPair(), true, IcpMetric::PointToPlane); }
void BM_Kitti_Hazmap_Icp_Plane(benchmark::State& s) { hazmapIcp(s, kittiPair(), false, IcpMetric::PointToPlane); }
BENCHMARK(BM_ScanPair_Hazmap_PropertyIcp_Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Hazmap_PropertyIcp_Point)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Hazmap_Icp_Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Hazmap_Icp_Point)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Hazmap_PropertyIcp_Plane_Sequential)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_Kitti_Hazmap_PropertyIcp_Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_Kitti_Hazmap_Icp_Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();

/// No ground truth for these scans: the reference trajectory is hazmap's own frame-to-map run at
/// 0.25 m voxels with tight tolerances, used to compare the settings' answers (max_err_cm/deg).
const std::vector<Eigen::Isometry3d>& kittiFineTrajectory(const std::vector<LabeledCloud>& scans,
                                                          const ClassTable& table) {
  static const std::vector<Eigen::Isometry3d> poses = [&] {
    OdometryConfig fine;
    fine.voxel_size = 0.25;
    fine.registration.max_iterations = 100;
    fine.registration.translation_tolerance = fine.registration.rotation_tolerance = 1e-6;
    Odometry odo(table, fine);
    std::vector<Eigen::Isometry3d> out;
    for (const auto& s : scans) out.push_back(odo.addFrame(s).pose);
    return out;
  }();
  return poses;
}

void hazmapOdometry(benchmark::State& state, OdometryMode mode, bool classes, bool dense_preset = false) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(0));
  const ClassTable table = ClassTable::semanticKitti();
  std::vector<LabeledCloud> scans;
  for (int i = 0; i < 6; ++i) scans.push_back(kittiScan(i, table));
  // The shipped preset for 64/128-beam sensors, read from the file users pass to --config.
  OdometryConfig cfg = dense_preset ? loadOdometryConfig(std::string(HAZMAP_SOURCE_DIR) + "/config/odometry/dense_lidar.yaml")
                                    : OdometryConfig::defaults();
  cfg.mode = mode;
  cfg.registration.use_classes = classes;
  const auto& ref = kittiFineTrajectory(scans, table);  // before the timed loop
  std::size_t frames = 0;
  double wall_ms = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Odometry odo(table, cfg);
    for (const auto& s : scans) odo.addFrame(s);
    wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    frames += scans.size();
    benchmark::DoNotOptimize(odo.frames().back().pose);
    if (frames == scans.size()) {  // first pass: the answer's distance to the fine run
      double et = 0.0, er = 0.0;
      for (std::size_t i = 0; i < ref.size(); ++i) {
        const Eigen::Isometry3d e = ref[i].inverse() * odo.frames()[i].pose;
        et = std::max(et, e.translation().norm());
        er = std::max(er, rotationAngle(e));
      }
      state.counters["max_err_cm"] = et * 100.0;
      state.counters["max_err_deg"] = er * 180.0 / M_PI;
    }
  }
  state.counters["ms_per_frame"] = frames ? wall_ms / static_cast<double>(frames) : 0.0;
}
void BM_KittiOdometry_Map_Property(benchmark::State& s) { hazmapOdometry(s, OdometryMode::FrameToMap, true); }
void BM_KittiOdometry_Map_Plain(benchmark::State& s) { hazmapOdometry(s, OdometryMode::FrameToMap, false); }
void BM_KittiOdometry_Frame_Property(benchmark::State& s) { hazmapOdometry(s, OdometryMode::FrameToFrame, true); }
void BM_KittiOdometry_Map_Property_DensePreset(benchmark::State& s) { hazmapOdometry(s, OdometryMode::FrameToMap, true, true); }
void BM_KittiOdometry_Map_Plain_DensePreset(benchmark::State& s) { hazmapOdometry(s, OdometryMode::FrameToMap, false, true); }
BENCHMARK(BM_KittiOdometry_Map_Property)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_KittiOdometry_Map_Plain)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK(BM_KittiOdometry_Map_Property_DensePreset)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_KittiOdometry_Map_Plain_DensePreset)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(5);
BENCHMARK(BM_KittiOdometry_Frame_Property)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(3);

// Simulated VLP-16 (naraha scenario, 60 frames, scans generated once in the setup) with the
// crawler's wheel-odometry increments as the guess, as `hazmap run` does. Times Odometry::addFrame
// only; frames/s over wall time.
struct SimFrames {
  ClassTable table;
  std::vector<LabeledCloud> scans;
  std::vector<Eigen::Isometry3d> wheel;  ///< previous ← current, from the simulated encoders
};
const SimFrames& simFrames() {
  static const SimFrames d = [] {
    sim::SimulatorConfig sc;
    sc.scenario = "naraha";
    sc.max_frames = 60;
    const sim::Simulator simulator(sc);
    SimFrames f;
    f.table = simulator.classTable();
    for (std::size_t i = 0; i < simulator.frames(); ++i) {
      f.scans.push_back(simulator.scan(i));
      f.wheel.push_back(i == 0 ? Eigen::Isometry3d::Identity()
                               : Eigen::Isometry3d(simulator.odometry()[i - 1].inverse() * simulator.odometry()[i]));
    }
    return f;
  }();
  return d;
}
void hazmapSimOdometry(benchmark::State& state, bool classes) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(0));
  const SimFrames& d = simFrames();
  OdometryConfig cfg = OdometryConfig::defaults();
  cfg.registration.use_classes = classes;
  std::size_t frames = 0;
  double wall_ms = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Odometry odo(d.table, cfg);
    for (std::size_t i = 0; i < d.scans.size(); ++i)
      odo.addFrame(d.scans[i], i == 0 ? std::nullopt : std::optional(d.wheel[i]));
    wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    frames += d.scans.size();
    benchmark::DoNotOptimize(odo.frames().back().pose);
  }
  state.counters["ms_per_frame"] = frames ? wall_ms / static_cast<double>(frames) : 0.0;
  state.counters["frames/s"] = wall_ms > 0.0 ? 1e3 * static_cast<double>(frames) / wall_ms : 0.0;
}
void BM_SimVlp16Odometry_Map_Property(benchmark::State& s) { hazmapSimOdometry(s, true); }
void BM_SimVlp16Odometry_Map_Plain(benchmark::State& s) { hazmapSimOdometry(s, false); }
BENCHMARK(BM_SimVlp16Odometry_Map_Property)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_SimVlp16Odometry_Map_Plain)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(2);

#ifdef HAZMAP_BENCH_HAVE_PCL
using PclCloud = pcl::PointCloud<pcl::PointXYZ>;
PclCloud::Ptr toPcl(const LabeledCloud& c) {
  PclCloud::Ptr out(new PclCloud);
  out->reserve(c.size());
  for (const auto& p : c.points) out->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  return out;
}
PclCloud::Ptr pclDown(const PclCloud::Ptr& in, float v) {
  pcl::VoxelGrid<pcl::PointXYZ> g;
  g.setLeafSize(v, v, v);
  g.setInputCloud(in);
  PclCloud::Ptr out(new PclCloud);
  g.filter(*out);
  return out;
}
template <typename Reg>
void pclRun(benchmark::State& state, const PairData& d) {
  const auto s_raw = toPcl(d.source), t_raw = toPcl(d.target);
  Eigen::Matrix4f T = Eigen::Matrix4f::Identity();
  for (auto _ : state) {
    const auto s = pclDown(s_raw, d.voxel), t = pclDown(t_raw, d.voxel);
    Reg reg;
    reg.setInputSource(s);
    reg.setInputTarget(t);
    reg.setMaxCorrespondenceDistance(1.0);
    reg.setMaximumIterations(50);
    reg.setTransformationEpsilon(1e-8);
    PclCloud aligned;
    reg.align(aligned);
    T = reg.getFinalTransformation();
  }
  Eigen::Isometry3d Td;
  Td.matrix() = T.cast<double>();
  report(state, Td, d.reference, -1);
}
void BM_ScanPair_PCL_ICP(benchmark::State& s) { pclRun<pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>(s, scanPair()); }
void BM_ScanPair_PCL_GICP(benchmark::State& s) { pclRun<pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ>>(s, scanPair()); }
BENCHMARK(BM_ScanPair_PCL_ICP)->Arg(1)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_PCL_GICP)->Arg(1)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
#endif

#ifdef HAZMAP_BENCH_HAVE_OPEN3D
namespace o3r = open3d::pipelines::registration;
enum class O3dKind { P2P, P2Plane, GICP };
void open3dRun(benchmark::State& state, const PairData& d, O3dKind kind) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  open3d::geometry::PointCloud s_raw, t_raw;
  for (const auto& p : d.source.points) s_raw.points_.push_back(p.cast<double>());
  for (const auto& p : d.target.points) t_raw.points_.push_back(p.cast<double>());
  o3r::RegistrationResult r;
  for (auto _ : state) {
    auto s = s_raw.VoxelDownSample(d.voxel);
    auto t = t_raw.VoxelDownSample(d.voxel);
    const o3r::ICPConvergenceCriteria crit(1e-6, 1e-6, 50);
    if (kind == O3dKind::P2P) {
      r = o3r::RegistrationICP(*s, *t, 1.0, Eigen::Matrix4d::Identity(),
                               o3r::TransformationEstimationPointToPoint(), crit);
    } else if (kind == O3dKind::P2Plane) {
      t->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(1.0, 10));
      r = o3r::RegistrationICP(*s, *t, 1.0, Eigen::Matrix4d::Identity(),
                               o3r::TransformationEstimationPointToPlane(), crit);
    } else {
      r = o3r::RegistrationGeneralizedICP(*s, *t, 1.0, Eigen::Matrix4d::Identity(),
                                          o3r::TransformationEstimationForGeneralizedICP(), crit);
    }
  }
  Eigen::Isometry3d T;
  T.matrix() = r.transformation_;
  report(state, T, d.reference, -1);
}
void BM_ScanPair_Open3D_P2P(benchmark::State& s) { open3dRun(s, scanPair(), O3dKind::P2P); }
void BM_ScanPair_Open3D_P2Plane(benchmark::State& s) { open3dRun(s, scanPair(), O3dKind::P2Plane); }
void BM_ScanPair_Open3D_GICP(benchmark::State& s) { open3dRun(s, scanPair(), O3dKind::GICP); }
void BM_Kitti_Open3D_P2Plane(benchmark::State& s) { open3dRun(s, kittiPair(), O3dKind::P2Plane); }
BENCHMARK(BM_ScanPair_Open3D_P2P)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Open3D_P2Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_ScanPair_Open3D_GICP)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
BENCHMARK(BM_Kitti_Open3D_P2Plane)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->MinWarmUpTime(0.3)->Repetitions(5)->ReportAggregatesOnly();
#endif

}  // namespace

HAZMAP_BENCHMARK_MAIN()
