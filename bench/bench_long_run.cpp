// A long SLAM run: does memory stay bounded?
//
// The simulated naraha route is one closed loop; the benchmark strings its first lap together
// HAZMAP_LONG_RUN_FRAMES times over (default 10,000 frames; the scans are hard links, so the
// sequence costs no disk) and runs the whole pipeline on it: tracking, and for the PGO method
// keyframes, loop closure on every revisit, online optimisation. Counters: frames/s, the
// process's resident memory after 10 % of the frames and at the end, the peak, the keyframe
// clouds held in memory (bounded by loop_closure.resident_keyframes), and the graph's size. The
// global map (bounded by its voxel cap) is assembled from the final poses afterwards by `hazmap
// run` and measured separately in bench_map's BM_GlobalMapLongRun.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include <sys/resource.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "hazmap/core/se3.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

double residentMb() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

double peakMb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;
}

std::size_t requestedFrames() {
  const char* env = std::getenv("HAZMAP_LONG_RUN_FRAMES");
  return env ? std::strtoul(env, nullptr, 10) : 10000;
}

// The laps sequence, built once per process.
const fs::path& lapsSequence() {
  static const fs::path dir = [] {
    const fs::path root = fs::temp_directory_path() / ("hazmap-bench-long-" + std::to_string(::getpid()));
    fs::remove_all(root);
    sim::SimulatorConfig c;  // naraha, the specified defaults
    const fs::path base = root / "base";
    sim::writeSimulation(c, base);
    const Trajectory truth = readKittiTrajectory(base / "poses.txt");
    const Trajectory odo = readKittiTrajectory(base / "odometry.txt");
    // One lap: up to the frame after 100 that comes closest to the start.
    std::size_t lap = truth.size();
    double best = 1e9;
    for (std::size_t i = 100; i < truth.size(); ++i) {
      const double d = truth.poses[i].translation().norm();
      if (d < best) best = d, lap = i;
    }
    const fs::path seq = root / "laps";
    fs::create_directories(seq / "velodyne");
    fs::create_directories(seq / "labels");
    fs::copy_file(base / "hazmap.yaml", seq / "hazmap.yaml");
    const std::size_t n = requestedFrames();
    Trajectory t_out, o_out;
    Eigen::Isometry3d odo_pose = Eigen::Isometry3d::Identity();
    char name[32];
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t k = j % lap;
      std::snprintf(name, sizeof name, "%06zu", k);
      std::string out(name);
      std::snprintf(name, sizeof name, "%06zu", j);
      fs::create_hard_link(base / "velodyne" / (out + ".bin"), seq / "velodyne" / (std::string(name) + ".bin"));
      fs::create_hard_link(base / "labels" / (out + ".label"), seq / "labels" / (std::string(name) + ".label"));
      t_out.push_back(static_cast<double>(j), truth.poses[k]);
      if (j > 0) {
        const std::size_t p = (j - 1) % lap;
        // Across the lap boundary the encoders report the true (small) step.
        const Eigen::Isometry3d inc = k == 0 ? truth.poses[p].inverse() * truth.poses[k]
                                             : odo.poses[p].inverse() * odo.poses[k];
        odo_pose = normalized(odo_pose * inc);
      }
      o_out.push_back(static_cast<double>(j), odo_pose);
    }
    writeKittiTrajectory(seq / "poses.txt", t_out);
    writeKittiTrajectory(seq / "odometry.txt", o_out);
    std::atexit([] { fs::remove_all(fs::temp_directory_path() / ("hazmap-bench-long-" + std::to_string(::getpid()))); });
    return seq;
  }();
  return dir;
}

void longRun(benchmark::State& state, SlamMethod method) {
  const Sequence sequence = Sequence::open(lapsSequence());
  const std::size_t n = sequence.size();
  for (auto _ : state) {
    const double start_mb = residentMb();
    double at_tenth = 0.0;
    SlamConfig cfg = SlamConfig::forMethod(method);
    const SlamResult r = runSlam(sequence, cfg, [&](std::size_t done, std::size_t) {
      if (done == n / 10) at_tenth = residentMb();
    });
    state.counters["frames"] = static_cast<double>(n);
    state.counters["frames_per_s"] = r.framesPerSecond();
    state.counters["loops"] = static_cast<double>(r.loops.size());
    state.counters["keyframes"] = static_cast<double>(r.keyframes);
    state.counters["rss_start_MB"] = start_mb;
    state.counters["rss_at_10pct_MB"] = at_tenth;
    state.counters["rss_end_MB"] = residentMb();
    state.counters["peak_rss_MB"] = peakMb();
    state.counters["graph_edges"] = static_cast<double>(r.graph.edges.size());
  }
}

void BM_LongRun_Icp(benchmark::State& s) { longRun(s, SlamMethod::Icp); }
void BM_LongRun_PropertyIcpPgo(benchmark::State& s) { longRun(s, SlamMethod::PropertyIcpPgo); }
BENCHMARK(BM_LongRun_Icp)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_LongRun_PropertyIcpPgo)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
