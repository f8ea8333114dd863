// Online cost of the back end (issue 14): frames/s of property-icp+pgo (loops, submap
// verification, basin probes, online PGO) on the whole simulated naraha route, against plain
// property-icp on the same sequence in the same run. Frame-to-map tracking (the default), 2
// threads (the target: >= 100 frames/s).
//
// The machine these run on is shared, so each row reports wall *and* process CPU time (all
// threads, getrusage) and the ratios to the peer's: frames_per_s / frames_per_cpu_s, and
// x_tracking_wall / x_tracking_cpu = this row's time ÷ property-icp's. The split of the row's wall
// time: tracking_s (preprocessing, ICP, local map), loop_s (keyframes, landmarks, loop search and
// verification), graph_s (optimisations). The peer must run first (registration order).
//   BM_Naraha_PropertyIcp                   tracking alone (the peer)
//   BM_Naraha_PropertyIcpPgo                the defaults (loops searched on every keyframe, each
//                                           keyframe's loop stage beside the next scan's tracking)
//   BM_Naraha_PropertyIcpPgo_Sequential     slam.back_end after-frame: the loop stage after
//                                           tracking (same results; the overlap's gain)
//   BM_Naraha_PropertyIcpPgo_Every2nd       slam.loop_search_every = 2: half the loop searches
//                                           (same naraha mean map error over seeds 1–8, but not
//                                           on every seed or scene: docs/measurements.md)
//   BM_Naraha_PropertyIcpPgo_CheapVerify    verification.full_from_coarse on (opt-in; the probe
//                                           knobs below are the defaults since 2026-12-02)
//   BM_Naraha_PropertyIcpPgo_SingleStageProbes  probe_coarse_points 0, probe_tolerance_scale 1
//                                           (the defaults before 2026-12-02)
//   BM_Naraha_PropertyIcpPgo_FullCrossChecks loop_closure.light_duplicate_keyframes = 0: every
//                                           accepted loop runs its own reverse cross-check (the
//                                           behaviour before 2026-12-02; default 2: near-duplicates
//                                           of a fully checked loop that agree with it take over
//                                           its verdict)
//   BM_Naraha_PropertyIcpPgo_NoGuessCheck   guess_check_points 0, coarse_fitness_margin 0.1 (the
//                                           defaults before the fourth pass; same results)
//   BM_Naraha_PropertyIcpPgo_ExactSubmaps   loop_closure.submap_reuse_tolerance = 0: verification
//                                           targets rebuilt after every optimisation (the
//                                           behaviour before 2026-12-02; default 5 mm)
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <sys/resource.h>

#include <chrono>
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

double processCpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

struct Timed {
  double wall_s = 0.0, cpu_s = 0.0;
};
Timed peer;  // property-icp's, from this run

void runConfig(benchmark::State& state, const SlamConfig& config, bool is_peer) {
  const Sequence& seq = naraha();
  SlamConfig cfg = config;
  cfg.threads = 2;
  SlamResult r;
  Timed t;
  for (auto _ : state) {
    const double cpu0 = processCpuSeconds();
    const auto wall0 = std::chrono::steady_clock::now();
    r = runSlam(seq, cfg);
    t.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    t.cpu_s = processCpuSeconds() - cpu0;
  }
  if (is_peer) peer = t;
  const double frames = static_cast<double>(r.frames.size());
  state.counters["frames_per_s"] = frames / t.wall_s;
  state.counters["frames_per_cpu_s"] = frames / t.cpu_s;
  state.counters["cpu_s"] = t.cpu_s;
  state.counters["tracking_s"] = r.timings.tracking_s;
  state.counters["loop_s"] = r.timings.loop_s;
  state.counters["graph_s"] = r.timings.graph_s;
  state.counters["loops"] = static_cast<double>(r.loops.size());
  state.counters["light"] = static_cast<double>(r.loop_light_verifications);
  state.counters["searched_kf"] = static_cast<double>(r.keyframes_searched);
  if (peer.wall_s > 0.0) {
    state.counters["x_tracking_wall"] = t.wall_s / peer.wall_s;
    state.counters["x_tracking_cpu"] = t.cpu_s / peer.cpu_s;
  }
}

void BM_Naraha_PropertyIcp(benchmark::State& state) {
  runConfig(state, SlamConfig::forMethod(SlamMethod::PropertyIcp), /*is_peer=*/true);
}
void BM_Naraha_PropertyIcpPgo(benchmark::State& state) {
  runConfig(state, SlamConfig::forMethod(SlamMethod::PropertyIcpPgo), false);
}
void BM_Naraha_PropertyIcpPgo_Sequential(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.back_end = BackEndSchedule::AfterFrame;
  runConfig(state, c, false);
}
void BM_Naraha_PropertyIcpPgo_Every2nd(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_search_every = 2;
  runConfig(state, c, false);
}
// The cheaper verification of the first pass (docs/pose_graph.md "Online cost"): the full run
// refines every coarse answer, however far it moved from the guess (wrong loops under heavy drift).
void BM_Naraha_PropertyIcpPgo_CheapVerify(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.verification.full_from_coarse_within = 1e9;
  c.loop_closure.verification.probe_coarse_points = 1000;
  c.loop_closure.verification.probe_tolerance_scale = 10.0;
  runConfig(state, c, false);
}
// The basin probes single-stage at the verification's tolerances (the defaults before 2026-12-02).
void BM_Naraha_PropertyIcpPgo_SingleStageProbes(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.verification.probe_coarse_points = 0;
  c.loop_closure.verification.probe_tolerance_scale = 1.0;
  runConfig(state, c, false);
}
// Verification targets rebuilt whenever an optimisation moved their keyframes at all (before 2026-12-02).
void BM_Naraha_PropertyIcpPgo_ExactSubmaps(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.submap_reuse_tolerance = 0.0;
  runConfig(state, c, false);
}
// Every accepted loop cross-checked itself (before 2026-12-02; docs/pose_graph.md "Online cost, third pass").
void BM_Naraha_PropertyIcpPgo_FullCrossChecks(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.light_duplicate_keyframes = 0;
  runConfig(state, c, false);
}
// No overlap check at the guess and the coarse check's old 0.1 margin (before 2026-12-02, fourth
// pass): the same loops and trajectory bit for bit, more coarse and full ICP runs.
void BM_Naraha_PropertyIcpPgo_NoGuessCheck(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.verification.guess_check_points = 0;
  c.loop_closure.verification.coarse_fitness_margin = 0.1;
  runConfig(state, c, false);
}
// The full verification always from the candidate's guess (before 2026-12-03, fifth pass).
void BM_Naraha_PropertyIcpPgo_FullFromGuess(benchmark::State& state) {
  SlamConfig c = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  c.loop_closure.verification.full_from_coarse_within = 0.0;
  runConfig(state, c, false);
}
BENCHMARK(BM_Naraha_PropertyIcp)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_Sequential)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_Every2nd)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_CheapVerify)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_SingleStageProbes)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_ExactSubmaps)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_FullCrossChecks)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_FullFromGuess)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_Naraha_PropertyIcpPgo_NoGuessCheck)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

HAZMAP_BENCHMARK_MAIN()
