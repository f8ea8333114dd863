// Simulator speed: Embree BVH build for the naraha scene (apart), one VLP-16 scan (28,800 rays),
// the whole naraha sequence's scans on all cores, and the whole `hazmap simulate` run with its
// files. Frames/s are reported as the `frames/s` counter.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"
#include <tbb/parallel_for.h>

#include <filesystem>

#include "hazmap/sim/simulator.hpp"

using namespace hazmap;
using namespace hazmap::sim;

namespace {

const Simulator& narahaSimulator() {
  static const Simulator sim(SimulatorConfig{});
  return sim;
}

}  // namespace

static void BM_NarahaBvhBuild(benchmark::State& state) {
  const Scene scene = builtinScene("naraha");
  for (auto _ : state) {
    RayCaster caster(scene.mesh);
    benchmark::DoNotOptimize(caster.buildSeconds());
  }
  state.counters["triangles"] = static_cast<double>(scene.mesh.triangles.size());
}
BENCHMARK(BM_NarahaBvhBuild)->Unit(benchmark::kMillisecond);

// One frame on one thread (frames cycle through the route).
static void BM_NarahaScanOneThread(benchmark::State& state) {
  const Simulator& sim = narahaSimulator();
  std::size_t i = 0, points = 0;
  for (auto _ : state) {
    const LabeledCloud scan = sim.scan(i++ % sim.frames());
    points += scan.size();
    benchmark::DoNotOptimize(scan.points.data());
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["points/frame"] = static_cast<double>(points) / state.iterations();
}
BENCHMARK(BM_NarahaScanOneThread)->Unit(benchmark::kMillisecond)->UseRealTime();

// All frames of the naraha sequence, in parallel over frames (TBB, all cores); no file output,
// BVH already built.
static void BM_NarahaSequenceScansAllCores(benchmark::State& state) {
  const Simulator& sim = narahaSimulator();
  std::vector<std::size_t> sizes(sim.frames());
  for (auto _ : state) {
    tbb::parallel_for(std::size_t{0}, sim.frames(), [&](std::size_t i) { sizes[i] = sim.scan(i).size(); });
    benchmark::DoNotOptimize(sizes.data());
  }
  state.counters["frames"] = static_cast<double>(sim.frames());
  state.counters["route_m"] = sim.routeLength();
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations() * sim.frames()),
                                                  benchmark::Counter::kIsRate);
}
BENCHMARK(BM_NarahaSequenceScansAllCores)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);

// The complete `hazmap simulate --scenario naraha`: scene, BVH, scans, odometry, and writing the
// sequence directory (scans, labels, trajectories, reference map, scene mesh).
static void BM_NarahaWriteSequence(benchmark::State& state) {
  const auto out = std::filesystem::temp_directory_path() / "hazmap-bench-sim";
  std::size_t frames = 0;
  for (auto _ : state) {
    const SimulationSummary s = writeSimulation(SimulatorConfig{}, out, /*overwrite=*/true);
    frames = s.frames;
    state.counters["bvh_ms"] = 1e3 * s.bvh_seconds;
  }
  std::filesystem::remove_all(out);
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations() * frames),
                                                  benchmark::Counter::kIsRate);
}
BENCHMARK(BM_NarahaWriteSequence)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

HAZMAP_BENCHMARK_MAIN()
