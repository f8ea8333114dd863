// Online cost of the back end (issue 14): frames/s of property-icp+pgo (loops, submap
// verification, basin probes, online PGO) on the whole simulated naraha route, against plain
// property-icp on the same sequence in the same run. Frame-to-map tracking (the default).
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <filesystem>
#include <unistd.h>

#include "hazmap/io/sequence.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"

namespace {

using namespace hazmap;

const Sequence& naraha() {
  static const Sequence seq = [] {
    const auto dir = std::filesystem::temp_directory_path() / ("hazmap-bench-pgo-" + std::to_string(::getpid()));
    sim::SimulatorConfig c;  // naraha seed 1, the specified defaults
    sim::writeSimulation(c, dir, /*overwrite=*/true);
    return Sequence::open(dir);
  }();
  return seq;
}

void runMethod(benchmark::State& state, SlamMethod method) {
  const Sequence& seq = naraha();
  SlamConfig cfg = SlamConfig::forMethod(method);
  cfg.threads = 2;  // the target: 2 threads
  double fps = 0.0;
  std::size_t loops = 0;
  for (auto _ : state) {
    const SlamResult r = runSlam(seq, cfg);
    fps = r.framesPerSecond();
    loops = r.loops.size();
  }
  state.counters["frames_per_s"] = fps;
  state.counters["loops"] = static_cast<double>(loops);
}

void BM_Naraha_PropertyIcp(benchmark::State& state) { runMethod(state, SlamMethod::PropertyIcp); }
void BM_Naraha_PropertyIcpPgo(benchmark::State& state) { runMethod(state, SlamMethod::PropertyIcpPgo); }
BENCHMARK(BM_Naraha_PropertyIcp)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Naraha_PropertyIcpPgo)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
