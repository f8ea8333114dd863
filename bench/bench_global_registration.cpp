// Global registration (issue 19): hazmap's FPFH + RANSAC + constellations + property ICP against
// Open3D's FPFH + RANSAC (+ its point-to-plane ICP, so both end refined), same scans, same jumps,
// same run. Each benchmark iteration registers one scan after a known random jump (yaw up to
// ±180°, up to 3 m) and counts it correct when it is accepted within 0.2 m / 1° of the truth.
//
//   Vlp16Room:  the real VLP-16 bag (sensors/velodyne-vlp16), scan 3 → scan 0, a small room.
//   Vlp16Street: the real VLP-16 capture (sensors/velodyne-vlp16-pcap), its full rotation
//               registered to itself moved (another voxel grid after the move).
//   Ouster:     the real OS-1-128 capture, scan 2 → scan 0 (reference: ouster-sdk's poses).
//   Naraha:     simulated VLP-16 scans with heat/water/radiation classes, frame k+4 → k (truth).
// `…_Prepared` times a registration against a target prepared once (the tracking use: the local
// map's features are kept); `…_Pair` includes the target's features (like-for-like with Open3D).
// The SuccessRate benchmarks run once and report the success rate per size of the jump.
#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>

#include "bench_main.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sources/scan_source.hpp"

#ifdef HAZMAP_BENCH_HAVE_OPEN3D
#include <omp.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>
#endif

using namespace hazmap;

namespace {

const std::filesystem::path kData = HAZMAP_SHARED_DATA_DIR;
constexpr double kDeg = std::numbers::pi / 180.0;

struct Case {
  LabeledCloud source, target;
  Eigen::Isometry3d reference = Eigen::Isometry3d::Identity();  ///< target ← source
  ClassTable table = ClassTable::defaults();
};

std::vector<LabeledCloud> readScans(const std::filesystem::path& path) {
  std::vector<LabeledCloud> out;
  auto src = openScanSource(path);
  while (auto s = src->next()) out.push_back(std::move(s->cloud));
  return out;
}

// The reference of a pair without ground truth: property ICP from identity (stationary sensor).
Eigen::Isometry3d icpReference(const Case& c) {
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.2;
  return registerScans(c.source, c.target, Eigen::Isometry3d::Identity(), c.table, vd).transform;
}

const Case& vlp16Room() {
  static const Case c = [] {
    auto scans = readScans(kData / "sensors/velodyne-vlp16");
    Case k{scans.at(3), scans.at(0)};
    k.reference = icpReference(k);
    return k;
  }();
  return c;
}

const Case& vlp16Street() {
  static const Case c = [] {
    auto scans = readScans(kData / "sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap");
    return Case{scans.at(1), scans.at(1)};
  }();
  return c;
}

const Case& ouster() {
  static const Case c = [] {
    auto src = openScanSource(kData / "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
    std::vector<Scan> scans;
    while (auto s = src->next()) scans.push_back(std::move(*s));
    Case k{scans.at(2).cloud, scans.at(0).cloud};
    k.reference = icpReference(k);
    return k;
  }();
  return c;
}

const Case& naraha() {
  static const Case c = [] {
    sim::SimulatorConfig cfg;
    cfg.scenario = "naraha";
    cfg.seed = 3;
    cfg.max_frames = 60;
    const sim::Simulator sim(cfg);
    Case k{sim.scan(44), sim.scan(40)};
    k.reference = sim.groundTruth()[40].inverse() * sim.groundTruth()[44];
    k.table = sim.classTable();
    return k;
  }();
  return c;
}

Eigen::Isometry3d jump(std::mt19937& rng, double max_yaw_deg, double max_translation) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double yaw = u(rng) * max_yaw_deg * kDeg, heading = u(rng) * std::numbers::pi;
  const double dist = 0.5 * (u(rng) + 1.0) * max_translation;
  Eigen::Isometry3d J = Eigen::Isometry3d::Identity();
  J.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  J.translation() = Eigen::Vector3d(dist * std::cos(heading), dist * std::sin(heading), 0.0);
  return J;
}

std::vector<Eigen::Isometry3d> jumps(int n, double max_yaw_deg, double max_translation, unsigned seed = 5) {
  std::mt19937 rng(seed);
  std::vector<Eigen::Isometry3d> out;
  for (int k = 0; k < n; ++k) out.push_back(jump(rng, max_yaw_deg, max_translation));
  return out;
}

bool correct(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth) {
  const Eigen::Isometry3d e = estimate.inverse() * truth;
  return e.translation().norm() < 0.2 && Eigen::AngleAxisd(e.linear()).angle() < 1.0 * kDeg;
}

GlobalRegistrationConfig config(bool classes) {
  GlobalRegistrationConfig c;
  c.use_classes = classes;
  return c;
}

#ifdef HAZMAP_BENCH_HAVE_OPEN3D
/// Open3D's FPFH + RANSAC + ICP of c.source to c.target moved by J (defined below).
Eigen::Isometry3d open3dRegister(const Case& c, const Eigen::Isometry3d& J);
#endif

// ---------------------------------------------------------------------------------------------
void hazmapGlobal(benchmark::State& state, const Case& c, bool classes, bool prepared) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(0));
  const auto cfg = config(classes);
  const auto js = jumps(16, 180.0, 3.0);
  std::vector<LabeledCloud> moved;
  std::vector<GlobalRegistrationTarget> targets;
  for (const auto& J : js) {
    moved.push_back(c.target.transformed(J));
    if (prepared) targets.push_back(prepareGlobalTarget(moved.back(), c.table, cfg, J.translation().cast<float>()));
  }
  std::size_t k = 0, ok = 0, accepted = 0;
  double phases[4] = {0, 0, 0, 0}, points = 0, matches = 0;
  for (auto _ : state) {
    const std::size_t j = k++ % js.size();
    GlobalRegistrationResult r;
    if (prepared) {
      r = registerGlobally(c.source, targets[j], c.table, cfg);
    } else {
      const auto t = prepareGlobalTarget(moved[j], c.table, cfg, js[j].translation().cast<float>());
      r = registerGlobally(c.source, t, c.table, cfg);
    }
    accepted += r.success;
    ok += r.success && correct(r.transform, js[j] * c.reference);
    phases[0] += r.timings.prepare_ms;
    phases[1] += r.timings.match_ms;
    phases[2] += r.timings.hypotheses_ms;
    phases[3] += r.timings.refine_ms;
    points += static_cast<double>(r.source_points);
    matches += static_cast<double>(r.correspondences);
  }
  const double n = static_cast<double>(std::max<std::size_t>(k, 1));
  state.counters["features_ms"] = phases[0] / n;
  state.counters["match_ms"] = phases[1] / n;
  state.counters["hypotheses_ms"] = phases[2] / n;
  state.counters["refine_ms"] = phases[3] / n;
  state.counters["points"] = points / n;
  state.counters["matches"] = matches / n;
  state.counters["correct"] = static_cast<double>(ok) / static_cast<double>(std::max<std::size_t>(k, 1));
  state.counters["accepted"] = static_cast<double>(accepted) / static_cast<double>(std::max<std::size_t>(k, 1));
}

#define HAZMAP_GLOBAL_BENCH(name, data, classes, prepared)                                          \
  void BM_##name(benchmark::State& s) { hazmapGlobal(s, data(), classes, prepared); }               \
  BENCHMARK(BM_##name)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(16)->Repetitions(3) \
      ->ReportAggregatesOnly();

HAZMAP_GLOBAL_BENCH(Vlp16Room_Hazmap_Prepared, vlp16Room, false, true)
HAZMAP_GLOBAL_BENCH(Vlp16Room_Hazmap_Pair, vlp16Room, false, false)
HAZMAP_GLOBAL_BENCH(Vlp16Street_Hazmap_Prepared, vlp16Street, false, true)
HAZMAP_GLOBAL_BENCH(Vlp16Street_Hazmap_Pair, vlp16Street, false, false)
HAZMAP_GLOBAL_BENCH(Ouster_Hazmap_Prepared, ouster, false, true)
HAZMAP_GLOBAL_BENCH(Ouster_Hazmap_Pair, ouster, false, false)
HAZMAP_GLOBAL_BENCH(Naraha_Hazmap_Plain_Prepared, naraha, false, true)
HAZMAP_GLOBAL_BENCH(Naraha_Hazmap_Property_Prepared, naraha, true, true)
HAZMAP_GLOBAL_BENCH(Naraha_Hazmap_Property_Pair, naraha, true, false)

// ---------------------------------------------------------------------------------------------
#ifdef HAZMAP_BENCH_HAVE_OPEN3D
namespace o3r = open3d::pipelines::registration;

std::shared_ptr<open3d::geometry::PointCloud> o3dPrepared(const LabeledCloud& cloud, const Eigen::Isometry3d& T,
                                                          const GlobalRegistrationConfig& cfg,
                                                          std::shared_ptr<o3r::Feature>& feature) {
  open3d::geometry::PointCloud raw;
  raw.points_.reserve(cloud.size());
  for (const auto& p : cloud.points) raw.points_.push_back(T * p.cast<double>());
  auto down = raw.VoxelDownSample(cfg.voxel_size);
  down->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(cfg.normal_radius, cfg.normal_neighbors));
  down->OrientNormalsTowardsCameraLocation(T.translation());
  feature = o3r::ComputeFPFHFeature(*down, open3d::geometry::KDTreeSearchParamHybrid(cfg.feature_radius, 100));
  return down;
}

// Open3D's documented global registration recipe (voxel v, normals 2v, FPFH 5v, RANSAC with the
// edge-length (0.9) and distance checkers, 100k iterations, confidence 0.999), then its
// point-to-plane ICP, with hazmap's voxel size and radii.
void open3dGlobal(benchmark::State& state, const Case& c) {
  omp_set_num_threads(static_cast<int>(state.range(0)));
  const auto js = jumps(16, 180.0, 3.0);
  std::size_t k = 0, ok = 0;
  for (auto _ : state) {
    const std::size_t j = k++ % js.size();
    ok += correct(open3dRegister(c, js[j]), js[j] * c.reference);
  }
  state.counters["correct"] = static_cast<double>(ok) / static_cast<double>(std::max<std::size_t>(k, 1));
}

Eigen::Isometry3d open3dRegister(const Case& c, const Eigen::Isometry3d& J) {
  const auto cfg = config(false);
  std::shared_ptr<o3r::Feature> fs, ft;
  auto s = o3dPrepared(c.source, Eigen::Isometry3d::Identity(), cfg, fs);
  auto t = o3dPrepared(c.target, J, cfg, ft);
  const o3r::CorrespondenceCheckerBasedOnEdgeLength edges(0.9);
  const o3r::CorrespondenceCheckerBasedOnDistance distance(cfg.inlier_distance);
  auto coarse = o3r::RegistrationRANSACBasedOnFeatureMatching(
      *s, *t, *fs, *ft, true, cfg.inlier_distance, o3r::TransformationEstimationPointToPoint(false), 3,
      {edges, distance}, o3r::RANSACConvergenceCriteria(100000, 0.999));
  auto fine = o3r::RegistrationICP(*s, *t, 1.0, coarse.transformation_, o3r::TransformationEstimationPointToPlane(),
                                   o3r::ICPConvergenceCriteria(1e-6, 1e-6, 30));
  Eigen::Isometry3d T;
  T.matrix() = fine.transformation_;
  return T;
}

#define HAZMAP_OPEN3D_BENCH(name, data)                                                            \
  void BM_##name(benchmark::State& s) { open3dGlobal(s, data()); }                                  \
  BENCHMARK(BM_##name)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->Iterations(16)->Repetitions(3) \
      ->ReportAggregatesOnly();

HAZMAP_OPEN3D_BENCH(Vlp16Room_Open3D_FpfhRansac, vlp16Room)
HAZMAP_OPEN3D_BENCH(Vlp16Street_Open3D_FpfhRansac, vlp16Street)
HAZMAP_OPEN3D_BENCH(Ouster_Open3D_FpfhRansac, ouster)
HAZMAP_OPEN3D_BENCH(Naraha_Open3D_FpfhRansac, naraha)
#endif

// ---------------------------------------------------------------------------------------------
// Success rate vs size of the jump (docs/registration.md's table). Bucket b draws |yaw| uniformly
// in (kYaw[b-1], kYaw[b]] with a random sign and the translation in (kMove[b-1], kMove[b]] m, one
// jump per pair and trial; every method sees the same jumps. Counters: share of trials accepted
// and correct (0.2 m / 1°), share accepted but wrong (the dangerous case), mean ms per trial.
constexpr double kYaw[] = {0.0, 10.0, 45.0, 90.0, 180.0};
constexpr double kMove[] = {0.0, 0.5, 2.0, 3.0, 5.0};

Eigen::Isometry3d bucketJump(std::mt19937& rng, int b) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double yaw = (kYaw[b - 1] + u(rng) * (kYaw[b] - kYaw[b - 1])) * (u(rng) < 0.5 ? -1.0 : 1.0) * kDeg;
  const double dist = kMove[b - 1] + u(rng) * (kMove[b] - kMove[b - 1]);
  const double heading = (2.0 * u(rng) - 1.0) * std::numbers::pi;
  Eigen::Isometry3d J = Eigen::Isometry3d::Identity();
  J.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  J.translation() = Eigen::Vector3d(dist * std::cos(heading), dist * std::sin(heading), 0.0);
  return J;
}

const std::vector<Case>& narahaPairs() {
  static const std::vector<Case> pairs = [] {
    sim::SimulatorConfig cfg;
    cfg.scenario = "naraha";
    cfg.seed = 3;
    const sim::Simulator sim(cfg);
    std::vector<Case> out;
    const std::size_t n = sim.frames();
    for (std::size_t k = 0; k < 12; ++k) {
      const std::size_t f = 5 + k * (n - 10) / 12;  // places spread along the whole route
      Case c{sim.scan(f + 3), sim.scan(f)};
      c.reference = sim.groundTruth()[f].inverse() * sim.groundTruth()[f + 3];
      c.table = sim.classTable();
      out.push_back(std::move(c));
    }
    return out;
  }();
  return pairs;
}

const std::vector<Case>& kittiPairs() {
  static const std::vector<Case> pairs = [] {
    const ClassTable table = ClassTable::semanticKitti();
    auto scan = [&](int i) {
      char name[16];
      std::snprintf(name, sizeof name, "%06d", i);
      const auto dir = kData / "kitti-semantic-sample";
      return readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"), dir / "labels" / (std::string(name) + ".label"), table);
    };
    std::vector<Case> out;
    for (auto [s, t] : {std::pair{1, 0}, std::pair{2, 1}, std::pair{2, 0}}) {  // the labelled scans
      Case c{scan(s), scan(t)};
      c.table = table;
      c.reference = icpReference(c);
      out.push_back(std::move(c));
    }
    return out;
  }();
  return pairs;
}

struct Tally {
  int runs = 0, correct = 0, wrong = 0;
  double ms = 0.0;
  void add(bool accepted, bool right, double elapsed_ms) {
    ++runs;
    correct += accepted && right;
    wrong += accepted && !right;
    ms += elapsed_ms;
  }
  void report(benchmark::State& state, const std::string& name) const {
    state.counters[name + "_ok"] = runs ? static_cast<double>(correct) / runs : 0.0;
    state.counters[name + "_wrong"] = runs ? static_cast<double>(wrong) / runs : 0.0;
    state.counters[name + "_ms"] = runs ? ms / runs : 0.0;
  }
};

Tally hazmapTrial(const Case& c, const Eigen::Isometry3d& J, bool classes, Tally t) {
  const auto cfg = config(classes);
  const auto target = prepareGlobalTarget(c.target.transformed(J), c.table, cfg, J.translation().cast<float>());
  const auto r = registerGlobally(c.source, target, c.table, cfg);
  t.add(r.success, correct(r.transform, J * c.reference), r.timings.total_ms);
  return t;
}

void successRate(benchmark::State& state, const std::vector<Case>& pairs, int trials_per_pair) {
  const int b = static_cast<int>(state.range(0));
  Tally plain, property, peer;
  for (auto _ : state) {
    std::mt19937 rng(100 + b);
    for (int trial = 0; trial < trials_per_pair; ++trial)
      for (const Case& c : pairs) {
        const Eigen::Isometry3d J = bucketJump(rng, b);
        plain = hazmapTrial(c, J, false, plain);
        property = hazmapTrial(c, J, true, property);
#ifdef HAZMAP_BENCH_HAVE_OPEN3D
        const auto t0 = std::chrono::steady_clock::now();
        const Eigen::Isometry3d T = open3dRegister(c, J);
        peer.add(true, correct(T, J * c.reference),
                 std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
#endif
      }
  }
  state.counters["yaw_max_deg"] = kYaw[b];
  state.counters["move_max_m"] = kMove[b];
  plain.report(state, "plain");
  property.report(state, "property");
#ifdef HAZMAP_BENCH_HAVE_OPEN3D
  peer.report(state, "open3d");
#endif
}

void BM_SuccessRate_Naraha(benchmark::State& s) { successRate(s, narahaPairs(), 2); }
void BM_SuccessRate_Kitti(benchmark::State& s) { successRate(s, kittiPairs(), 4); }
BENCHMARK(BM_SuccessRate_Naraha)->DenseRange(1, 4)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_SuccessRate_Kitti)->DenseRange(1, 4)->Iterations(1)->Unit(benchmark::kSecond);

// The normal tracking path when nothing fails (issue 19: "the normal path unchanged"): frame-to-map
// property ICP on the simulated naraha route (60 frames, today's noise, wheel-odometry guess),
// with odometry.recovery.relocalise off (0) and on (1, the default), 2 threads. No frame triggers a
// recovery (counter `recoveries`), so the two rows should time alike; --benchmark_filter=NormalPath
// --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true compares them fairly.
void BM_NormalPath_Naraha(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  static const auto frames = [] {
    sim::SimulatorConfig sc;
    sc.scenario = "naraha";
    sc.max_frames = 60;
    const sim::Simulator simulator(sc);
    std::vector<std::pair<LabeledCloud, Eigen::Isometry3d>> out;
    for (std::size_t i = 0; i < simulator.frames(); ++i)
      out.emplace_back(simulator.scan(i), i == 0 ? Eigen::Isometry3d::Identity()
                                                 : Eigen::Isometry3d(simulator.odometry()[i - 1].inverse() *
                                                                     simulator.odometry()[i]));
    return std::make_pair(simulator.classTable(), out);
  }();
  OdometryConfig cfg = OdometryConfig::defaults();
  cfg.recovery.relocalise = state.range(0) != 0;
  std::size_t n = 0, recoveries = 0;
  double wall_ms = 0.0;
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    Odometry odo(frames.first, cfg);
    for (std::size_t i = 0; i < frames.second.size(); ++i)
      odo.addFrame(frames.second[i].first, i == 0 ? std::nullopt : std::optional(frames.second[i].second));
    wall_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    n += frames.second.size();
    for (const auto& f : odo.frames()) recoveries += f.global.tried;
    benchmark::DoNotOptimize(odo.frames().back().pose);
  }
  state.counters["frames/s"] = wall_ms > 0.0 ? 1e3 * static_cast<double>(n) / wall_ms : 0.0;
  state.counters["recoveries"] = static_cast<double>(recoveries);
}
BENCHMARK(BM_NormalPath_Naraha)->Arg(0)->Arg(1)->Iterations(2)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
