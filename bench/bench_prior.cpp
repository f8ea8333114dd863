// Localisation in a prior map (issue 34; docs/missions.md "Cost"): what one search attempt costs
// and what preparing the prior costs as the prior grows. The prior is the map folder of a naraha
// run (about 160 keyframes) and the same keyframes six times side by side, 60 m apart (about
// 1,000 keyframes, every answer ambiguous by construction, as scripts/replicate_map.py builds it).
// No other tool localises in a prior map, so the peer is hazmap's own attempt in the small prior,
// measured in the same run: the ratio says how the cost grows with the prior.
//
//   BM_PriorPrepare/<copies>/<stored>: open the map folder and prepare the prior's search
//                                      (PriorIndex), then one query's attempts: the whole cost of
//                                      localising in a prior. stored=1: from the map folder's
//                                      search overview (what `hazmap run` writes), keyframe clouds
//                                      read only for the verification's submaps; stored=0: the
//                                      same folder without it (an older map), every keyframe read.
//                                      Counters: open_s (checksums), prepare_s, attempt_s (per
//                                      attempt), ready_s = open_s + prepare_s + attempt_s (a
//                                      first answer), keyframes_read, target_points (the same
//                                      with and without the stored overview).
//   BM_PriorAttempt/<copies>/<threads>: one keyframe's attempt (a query of three keyframes,
//                                      global registration against the whole prior, property-ICP
//                                      verification of its answer): what the 1 s target covers.
#include <tbb/global_control.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "bench_main.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "hazmap/sim/simulator.hpp"
#include "pipeline/prior_overview.hpp"
#include "pipeline/prior_search.hpp"

using namespace hazmap;
using namespace hazmap::pipeline_detail;
namespace fs = std::filesystem;

namespace {

// This process's maps (about 550 MB): removed when the process ends, after everything that reads
// them (function statics are destroyed in reverse order of construction).
struct OwnFolder {
  fs::path dir = fs::temp_directory_path() / ("hazmap-bench-prior-" + std::to_string(::getpid()));
  ~OwnFolder() {
    std::error_code ec;
    fs::remove_all(dir, ec);
  }
};
const fs::path& work() {
  static const OwnFolder folder;
  return folder.dir;
}
constexpr double kCopySpacing = 60.0;  // m between the copies (the hall is 40 m × 24 m)

// A naraha run's map folder, made once.
const fs::path& narahaMap() {
  static const fs::path dir = [] {
    sim::SimulatorConfig c;
    c.scenario = "naraha";
    c.seed = 1;
    sim::writeSimulation(c, work() / "seq", /*overwrite=*/true);
    const Sequence seq = Sequence::open(work() / "seq");
    const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
    OutputConfig outputs;
    outputs.write_pngs = outputs.write_viewer = false;
    writeRunOutputs(seq, runSlam(seq, config), config, outputs, work() / "map1");
    return work() / "map1";
  }();
  return dir;
}

// The map's keyframes `copies` times side by side (the first copy where it was).
fs::path replicated(int copies) {
  if (copies == 1) return narahaMap();
  const fs::path dir = work() / ("map" + std::to_string(copies));
  if (fs::exists(dir / "map.json")) return dir;
  const MapFolder map = openMap(narahaMap());
  fs::create_directories(dir);
  for (const char* f : {"graph.g2o", "trajectory.kitti", "hazards.json"})
    fs::copy_file(narahaMap() / f, dir / f, fs::copy_options::overwrite_existing);
  MapManifest m = map.manifest();
  m.keyframes.clear();
  m.frames *= static_cast<std::size_t>(copies);
  for (int c = 0; c < copies; ++c)
    for (const auto& k : map.keyframes()) {
      MapKeyframe copy = k;
      copy.frame = k.frame + static_cast<std::size_t>(c) * map.manifest().frames;
      copy.pose.pretranslate(Eigen::Vector3d(kCopySpacing * c, 0.0, 0.0));
      copy.cloud = copyMapKeyframeCloud(dir, copy.frame, narahaMap() / k.cloud);
      m.keyframes.push_back(std::move(copy));
    }
  const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  m.search_overview = writeSearchOverview(dir, m, map.classes(), config.property_icp.applyTo(map.classes()));
  writeMapManifest(dir, m, map.classes(), {"graph.g2o", "trajectory.kitti", "hazards.json"});
  return dir;
}

// The same map as an older hazmap left it: no search overview (its files linked, not copied).
fs::path withoutOverview(const fs::path& map) {
  const fs::path dir = map.string() + "-plain";
  if (fs::exists(dir / "map.json")) return dir;
  fs::create_directories(dir / "keyframes");
  for (const auto& e : fs::recursive_directory_iterator(map))
    if (e.is_regular_file() && e.path().filename() != "map.json")
      fs::create_hard_link(e.path(), dir / fs::relative(e.path(), map));
  nlohmann::json j = nlohmann::json::parse(readTextFile(map / "map.json"));
  j.erase("search_overview");
  writeTextAtomically(dir / "map.json", j.dump(1));
  return dir;
}

struct Prepared {
  SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  ClassTable classes;
  std::unique_ptr<PriorIndex> index;
  RunKeyframes queries;
  FramePoses poses;
};

const Prepared& prepared(int copies) {
  static std::map<int, Prepared> cache;
  auto [it, fresh] = cache.try_emplace(copies);
  if (!fresh) return it->second;
  Prepared& p = it->second;
  const MapFolder map = openMap(replicated(copies)), own = openMap(narahaMap());
  p.classes = p.config.property_icp.applyTo(map.classes(), map.dir().string());
  p.index = std::make_unique<PriorIndex>(map, p.classes, p.config);
  p.queries = mapKeyframes(own, p.classes);
  p.poses.resize(own.manifest().frames);
  for (const auto& k : own.keyframes()) p.poses[k.frame] = k.pose;
  return p;
}

void BM_PriorPrepare(benchmark::State& state) {
  const fs::path stored = replicated(static_cast<int>(state.range(0)));
  const fs::path dir = state.range(1) ? stored : withoutOverview(stored);
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
  const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  using Clock = std::chrono::steady_clock;
  const auto seconds = [](Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
  const Prepared& q = prepared(1);  // the queries
  for (auto _ : state) {
    const auto t0 = Clock::now();
    const MapFolder map = openMap(dir);
    const ClassTable classes = config.property_icp.applyTo(map.classes(), map.dir().string());
    const auto t1 = Clock::now();
    const PriorIndex index(map, classes, config);
    const auto t2 = Clock::now();
    // One query (keyframes 18-20 of the naraha map, as BM_PriorAttempt's first): up to three
    // attempts.
    RunKeyframes one;
    for (std::size_t j = 18; j <= 20; ++j) one.frames.push_back(q.queries.frames[j]), one.clouds.push_back(q.queries.clouds[j]);
    PriorLocalisation out;
    searchPrior(index, one, q.poses, classes, config, out);
    const auto t3 = Clock::now();
    if (index.usedStoredOverview() != (state.range(1) != 0)) state.SkipWithError("the stored overview was not used as asked");
    const double attempt = seconds(t2, t3) / static_cast<double>(std::max<std::size_t>(1, out.search.size()));
    state.counters["keyframes"] = static_cast<double>(index.size());
    state.counters["open_s"] = seconds(t0, t1);
    state.counters["prepare_s"] = seconds(t1, t2);
    state.counters["attempt_s"] = attempt;
    state.counters["ready_s"] = seconds(t0, t2) + attempt;
    state.counters["keyframes_read"] = static_cast<double>(index.keyframesRead());
    state.counters["target_points"] = static_cast<double>(index.overview().size());  // stored = rebuilt
  }
}
// Before the first iteration: the simulated run and the replicated maps (Prepared too).
BENCHMARK(BM_PriorPrepare)->Args({1, 0})->Args({1, 1})->Args({6, 0})->Args({6, 1})->Iterations(1)->UseRealTime()->Unit(benchmark::kSecond);

void BM_PriorAttempt(benchmark::State& state) {
  const Prepared& p = prepared(static_cast<int>(state.range(0)));
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, state.range(1));
  std::size_t k = 20, localised = 0, attempts = 0;  // queries walk along the route
  for (auto _ : state) {
    RunKeyframes one;
    const std::size_t first = k - 2;
    for (std::size_t j = first; j <= k; ++j) {
      one.frames.push_back(p.queries.frames[j]);
      one.clouds.push_back(p.queries.clouds[j]);
    }
    PriorLocalisation out;
    // Up to three attempts (one per keyframe): two agreeing answers localise after the second.
    searchPrior(*p.index, one, p.poses, p.classes, p.config, out);
    localised += out.state == PriorState::Localised;
    attempts += out.search.size();
    k = 20 + (k + 7) % (p.queries.frames.size() - 22);
  }
  state.counters["keyframes"] = static_cast<double>(p.index->size());
  state.counters["localised"] = static_cast<double>(localised);
  // Seconds per attempt (the counter is a rate of attempts, inverted).
  state.counters["s_per_attempt"] =
      benchmark::Counter(static_cast<double>(attempts), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_PriorAttempt)->Args({1, 2})->Args({6, 2})->Args({6, 1})->Iterations(8)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
