// Tracking on real scans with large motion (issue 35): hazmap's odometry (motion hypotheses on,
// and off = the constant-velocity guess as before) against a REIMPLEMENTATION of KISS-ICP
// (tests/support/kiss_icp_baseline.hpp; KISS-ICP itself cannot be built here), all fed the same
// scans in the same run. Cases (tests/support/stress_sequences.hpp): the six KITTI scans and the
// Ouster OS-1-128 capture with a sudden extra yaw from one scan on, turning every scan, and every
// k-th scan. One iteration = the whole sequence through a fresh tracker. Counters: ok = share of
// steps within 10 cm / 1° of the reference increment; turn_cm / turn_deg = the error of the turned
// (or largest) step; max_cm / max_deg = the worst step; ms_scan = mean wall ms per scan; worst_med
// = the slowest scan not called lost over the median; lost = scans hazmap called lost.
// Target (c) of the issue, mean ms per scan against the baseline on the same scans:
//   --benchmark_filter='kitti_(yaw0|drop[235])/(hazmap|kiss_icp_reimpl)/' --benchmark_repetitions=5
//   --benchmark_enable_random_interleaving=true   (ratios of the ms_scan medians, same run)
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <string>

#include "bench_main.hpp"
#include "stress_runs.hpp"

namespace {

using namespace hazmap;
constexpr double kDeg = M_PI / 180.0;
const std::filesystem::path kData = HAZMAP_SHARED_DATA_DIR;

const stress::Sequence& kitti() {
  static const stress::Sequence s = stress::kittiSequence(kData, ClassTable::semanticKitti());
  return s;
}
const stress::Sequence& ouster() {
  static const stress::Sequence s = stress::ousterSequence(kData);
  return s;
}

// The cases by name, built once.
const stress::Sequence& stressCase(const std::string& name) {
  static std::map<std::string, stress::Sequence> cases;
  if (auto it = cases.find(name); it != cases.end()) return it->second;
  const auto number = [&](std::size_t at) { return std::stod(name.substr(at)); };
  stress::Sequence s;
  if (name.rfind("kitti_yaw", 0) == 0) s = stress::suddenYaw(kitti(), 3, number(9) * kDeg);
  else if (name.rfind("kitti_turn", 0) == 0) s = stress::turning(kitti(), number(10) * kDeg);
  else if (name.rfind("kitti_drop", 0) == 0) s = stress::dropFrames(kitti(), static_cast<int>(number(10)));
  else if (name.rfind("ouster_yaw", 0) == 0) s = stress::suddenYaw(ouster(), 1, number(10) * kDeg);
  else if (name.rfind("ouster_drop", 0) == 0) s = stress::dropFrames(ouster(), static_cast<int>(number(11)));
  return cases.emplace(name, std::move(s)).first->second;
}

enum Tracker { kHazmap, kHazmapNoHypotheses, kHazmapPlain, kKiss, kHazmapCoarseSource };

stress::TrackRun track(const stress::Sequence& seq, Tracker t) {
  if (t == kKiss) return stress::runKiss(seq);
  OdometryConfig c;
  c.motion_hypotheses.enabled = t != kHazmapNoHypotheses;
  c.registration.use_classes = t != kHazmapPlain;
  if (t == kHazmapCoarseSource) c.source_voxel_size = 1.5;  // KISS-ICP's registered source: 1.5 x its 1 m voxel
  return stress::runHazmap(seq, ClassTable::semanticKitti(), c);
}

void BM_Track(benchmark::State& state, const std::string& name, Tracker tracker) {
  const stress::Sequence& seq = stressCase(name);
  stress::TrackRun run;
  double ms = 0.0;
  std::size_t scans = 0;
  for (auto _ : state) {
    run = track(seq, tracker);
    ms += run.meanMs() * static_cast<double>(run.ms.size());
    scans += run.ms.size();
  }
  const auto errors = stress::stepErrors(seq, run.poses);
  std::size_t ok = 0, turn = 0, worst = 0;
  for (std::size_t i = 0; i < errors.size(); ++i) {
    ok += stress::ok(errors[i]);
    if (errors[i].reference_yaw_deg > errors[turn].reference_yaw_deg) turn = i;
    if (errors[i].translation + errors[i].rotation_deg * 0.1 > errors[worst].translation + errors[worst].rotation_deg * 0.1)
      worst = i;
  }
  state.counters["ok"] = static_cast<double>(ok) / static_cast<double>(errors.size());
  state.counters["turn_cm"] = 100.0 * errors[turn].translation;
  state.counters["turn_deg"] = errors[turn].rotation_deg;
  state.counters["max_cm"] = 100.0 * errors[worst].translation;
  state.counters["max_deg"] = errors[worst].rotation_deg;
  state.counters["ms_scan"] = ms / static_cast<double>(std::max<std::size_t>(scans, 1));
  state.counters["worst_med"] = run.worstOverMedian();
  state.counters["lost"] = static_cast<double>(std::count(run.lost.begin(), run.lost.end(), 1));
}

const char* kTrackerNames[] = {"hazmap", "hazmap_no_hypotheses", "hazmap_plain_icp", "kiss_icp_reimpl",
                               "hazmap_source_voxel_1.5"};

int registerAll() {
  std::vector<std::string> names;
  for (int yaw : {0, 10, 20, 30, 45, 60, 90}) names.push_back("kitti_yaw" + std::to_string(yaw));
  for (int yaw : {10, 20, 30}) names.push_back("kitti_turn" + std::to_string(yaw));
  for (int k : {2, 3, 5}) names.push_back("kitti_drop" + std::to_string(k));
  for (int yaw : {0, 20, 45}) names.push_back("ouster_yaw" + std::to_string(yaw));
  names.push_back("ouster_drop2");
  for (const std::string& name : names)
    for (Tracker t : {kHazmap, kHazmapNoHypotheses, kHazmapPlain, kKiss, kHazmapCoarseSource})
      benchmark::RegisterBenchmark(("BM_Track/" + name + "/" + kTrackerNames[t]).c_str(),
                                   [name, t](benchmark::State& s) { BM_Track(s, name, t); })
          ->Unit(benchmark::kMillisecond)
          ->MinTime(0.5);
  return 0;
}
const int registered = registerAll();

}  // namespace

HAZMAP_BENCHMARK_MAIN();
