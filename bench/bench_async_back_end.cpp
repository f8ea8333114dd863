// The asynchronous back end (issue 33 part 3, slam.back_end own-thread): latency from a scan's
// arrival to its pose while loops are verified, and the tracking rate, against tracking alone in
// the same run. Whole simulated naraha route (seed 1, 163 frames, loops from frame 72), 2 threads.
//   BM_Paced10Hz        scans released at 10 Hz (a VLP-16's rate) by a source that waits for each
//                       one's time: *_p50_ms / *_p99_ms / *_max_ms = the frame hook's call (the
//                       pose exists) minus the scan's release (its last packet).
//   BM_AsFastAsTracking scans as fast as tracking takes them: *_frames_per_s = frames ÷ the wall
//                       time to the last frame's pose (the back end may still be finishing:
//                       *_backlog_s); *_x_rate = the row's rate ÷ tracking alone's.
// Each runs three rows in turn, the peer in the same run: alone (property-icp, tracking alone),
// async (property-icp+pgo, the back end on its own thread, working while tracking waits for the
// next scan: `hazmap live`'s; as fast as tracking goes it works after the last scan), sync (property-icp+pgo,
// the synchronous schedule, a keyframe's loop stage beside the next scan's tracking: `hazmap run`'s).
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <chrono>
#include <filesystem>
#include <thread>
#include <unistd.h>

#include "hazmap/io/sequence.hpp"
#include "hazmap/pipeline/frame_latency.hpp"
#include "hazmap/pipeline/slam.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sources/forwarding_source.hpp"

namespace {

using namespace hazmap;
using SteadyClock = std::chrono::steady_clock;

// This process's simulated sequence (93 MB): removed when the process ends, after the sequence
// that reads it (statics go in reverse order of construction).
struct OwnFolder {
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("hazmap-bench-async-" + std::to_string(::getpid()));
  ~OwnFolder() {
    std::error_code ec;
    std::filesystem::remove_all(dir, ec);
  }
};

const Sequence& naraha() {
  static const OwnFolder folder;
  static const Sequence seq = [] {
    sim::SimulatorConfig c;  // naraha seed 1, the specified defaults
    sim::writeSimulation(c, folder.dir, /*overwrite=*/true);
    return Sequence::open(folder.dir);
  }();
  return seq;
}

/// The sequence's scans, each released no earlier than start + index ÷ rate (rate 0: at once).
class PacedSource : public ForwardingScanSource {
 public:
  PacedSource(std::unique_ptr<ScanSource> inner, double rate) : ForwardingScanSource(std::move(inner)), rate_(rate) {}
  std::optional<Scan> next() override {
    std::optional<Scan> scan = ForwardingScanSource::next();
    if (!scan) return scan;
    if (released_.empty()) start_ = SteadyClock::now();
    if (rate_ > 0)
      std::this_thread::sleep_until(start_ + std::chrono::duration_cast<SteadyClock::duration>(
                                                 std::chrono::duration<double>(double(released_.size()) / rate_)));
    released_.push_back(SteadyClock::now());
    return scan;
  }
  SteadyClock::time_point released(std::size_t i) const { return released_.at(i); }
  SteadyClock::time_point start() const { return start_; }

 private:
  double rate_;
  SteadyClock::time_point start_{};
  std::vector<SteadyClock::time_point> released_;
};

double seconds(SteadyClock::duration d) { return std::chrono::duration<double>(d).count(); }

struct Row {
  double p50_ms = 0, p99_ms = 0, max_ms = 0, tracking_frames_per_s = 0, backlog_s = 0, loops = 0;
};

Row runRow(SlamMethod method, bool thread, double rate) {
  SlamConfig cfg = SlamConfig::forMethod(method);
  cfg.threads = 2;
  cfg.back_end = thread ? BackEndSchedule::OwnThread : BackEndSchedule::BesideTracking;
  PacedSource source(sequenceScanSource(naraha(), false), rate);
  FrameLatency latency;
  SteadyClock::time_point last_pose;
  SlamSnapshots hooks;
  hooks.frame = [&](const SlamFrameEvent& e) {
    last_pose = SteadyClock::now();
    latency.add(seconds(last_pose - source.released(e.record.index)));
  };
  const SlamResult r = runSlam(source, cfg, {}, hooks);
  const auto end = SteadyClock::now();
  return {latency.quantileMs(0.5), latency.quantileMs(0.99), latency.maxMs(),
          double(r.frames.size()) / seconds(last_pose - source.start()), seconds(end - last_pose), double(r.loops.size())};
}

// The three rows in one benchmark (the peer in the same run, whatever the benchmarks' order):
// tracking alone, the back end on its own thread, the synchronous schedule.
void runRows(benchmark::State& state, double rate) {
  for (auto _ : state) {
    const Row alone = runRow(SlamMethod::PropertyIcp, false, rate);
    const Row async = runRow(SlamMethod::PropertyIcpPgo, true, rate);
    const Row sync = runRow(SlamMethod::PropertyIcpPgo, false, rate);
    for (const auto& [name, row] : {std::pair{"alone", alone}, std::pair{"async", async}, std::pair{"sync", sync}}) {
      const std::string n = name;
      state.counters[n + "_p50_ms"] = row.p50_ms;
      state.counters[n + "_p99_ms"] = row.p99_ms;
      state.counters[n + "_max_ms"] = row.max_ms;
      state.counters[n + "_frames_per_s"] = row.tracking_frames_per_s;
      state.counters[n + "_backlog_s"] = row.backlog_s;
      if (n != "alone") state.counters[n + "_loops"] = row.loops;
      if (n != "alone") state.counters[n + "_x_rate"] = row.tracking_frames_per_s / alone.tracking_frames_per_s;
    }
  }
}

void BM_Paced10Hz(benchmark::State& s) { runRows(s, 10.0); }
void BM_AsFastAsTracking(benchmark::State& s) { runRows(s, 0.0); }
BENCHMARK(BM_Paced10Hz)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();
BENCHMARK(BM_AsFastAsTracking)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

}  // namespace

HAZMAP_BENCHMARK_MAIN()
