#include "hazmap/demo/demo_seeds.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <ostream>
#include <set>

#include "hazmap/core/error.hpp"
#include "hazmap/demo/demo_index.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

std::uint64_t parseSeed(std::string_view text, const std::string& where, const std::string& whole) {
  std::uint64_t v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size())
    fail(where, "expected seeds like 1-8 or 1,3,5, got '" + whole + "' ('" + std::string(text) + "' is not a seed)");
  return v;
}

constexpr std::size_t kMaxSeeds = 10000;

const std::vector<DemoRow>& rowsOf(const DemoReport& r, DemoSetUp setup) {
  switch (setup) {
    case DemoSetUp::FrameToMap: return r.map_rows;
    case DemoSetUp::CameraLabels: return r.camera_rows;
    default: return r.rows;
  }
}

constexpr DemoSetUp kSetUps[] = {DemoSetUp::FrameToFrame, DemoSetUp::FrameToMap, DemoSetUp::CameraLabels};

nlohmann::json statsJson(const SeedStats& s) {
  return {{"n", s.n}, {"mean", s.mean}, {"sd", s.sd}, {"min", s.min}, {"max", s.max}};
}

std::string rowTitle(SlamMethod method) { return paperRowTitle(method); }

}  // namespace

std::vector<std::uint64_t> parseSeedList(const std::string& text, const std::string& where) {
  std::vector<std::uint64_t> seeds;
  std::set<std::uint64_t> seen;
  auto add = [&](std::uint64_t s) {
    if (!seen.insert(s).second) fail(where, fmt::format("seed {} is listed twice in '{}'", s, text));
    if (seeds.size() >= kMaxSeeds) fail(where, fmt::format("more than {} seeds in '{}'", kMaxSeeds, text));
    seeds.push_back(s);
  };
  if (text.empty()) fail(where, "no seeds given (expected e.g. 1-8 or 1,3,5)");
  std::string_view rest = text;
  while (true) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    const auto dash = item.find('-');
    if (dash == std::string_view::npos) {
      add(parseSeed(item, where, text));
    } else {
      const std::uint64_t a = parseSeed(item.substr(0, dash), where, text);
      const std::uint64_t b = parseSeed(item.substr(dash + 1), where, text);
      if (b < a) fail(where, fmt::format("range {}-{} in '{}' runs backwards", a, b, text));
      if (b - a >= kMaxSeeds) fail(where, fmt::format("more than {} seeds in '{}'", kMaxSeeds, text));
      for (std::uint64_t s = a; s <= b; ++s) add(s);
    }
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }
  return seeds;
}

SeedStats seedStats(const std::vector<double>& values) {
  SeedStats s;
  s.n = values.size();
  if (values.empty()) return s;
  double sum = 0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(s.n);
  double ss = 0;
  for (double v : values) ss += (v - s.mean) * (v - s.mean);
  s.sd = s.n > 1 ? std::sqrt(ss / static_cast<double>(s.n - 1)) : 0.0;
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  s.min = *lo;
  s.max = *hi;
  return s;
}

const char* toString(DemoSetUp setup) {
  switch (setup) {
    case DemoSetUp::FrameToMap: return "frame_to_map";
    case DemoSetUp::CameraLabels: return "camera_labels";
    default: return "frame_to_frame";
  }
}

std::vector<SeedAggregateRow> aggregateSeeds(const std::vector<DemoReport>& reports) {
  std::vector<SeedAggregateRow> rows;
  if (reports.empty()) return rows;
  for (DemoSetUp setup : kSetUps) {
    for (const DemoRow& first : rowsOf(reports.front(), setup)) {
      std::vector<double> map, ate, fps, loops, nees_odometry, nees_loop;
      for (const DemoReport& r : reports)
        for (const DemoRow& row : rowsOf(r, setup))
          if (row.method == first.method) {
            map.push_back(row.map_error_m);
            ate.push_back(row.ate_m);
            fps.push_back(row.frames_per_s);
            loops.push_back(static_cast<double>(row.loops));
            if (row.odometry_edges) nees_odometry.push_back(row.nees_odometry);
            if (row.loop_edges) nees_loop.push_back(row.nees_loop);
          }
      rows.push_back({setup, first.method, seedStats(map), seedStats(ate), seedStats(fps), seedStats(loops),
                      seedStats(nees_odometry), seedStats(nees_loop)});
    }
  }
  return rows;
}

std::string formatSeedsTables(const SeedsReport& report) {
  std::string s;
  for (DemoSetUp setup : {DemoSetUp::FrameToFrame, DemoSetUp::FrameToMap}) {
    std::vector<SlamMethod> methods;
    for (const auto& a : report.aggregate)
      if (a.setup == setup) methods.push_back(a.method);
    if (methods.empty()) continue;
    s += fmt::format("\nMap error [m] per seed, {}\n{:<6}", setup == DemoSetUp::FrameToFrame ? "the paper's set-up (ICP frame to frame)" : "hazmap's frame-to-local-map tracking", "seed");
    for (SlamMethod m : methods) s += fmt::format(" {:>17}", toString(m));
    s += "\n";
    for (std::size_t k = 0; k < report.per_seed.size(); ++k) {
      s += fmt::format("{:<6}", report.seeds[k]);
      for (const DemoRow& row : rowsOf(report.per_seed[k], setup)) s += fmt::format(" {:>17.3f}", row.map_error_m);
      s += "\n";
    }
  }
  const bool f2m = std::any_of(report.aggregate.begin(), report.aggregate.end(),
                               [](const auto& a) { return a.setup == DemoSetUp::FrameToMap; });
  s += fmt::format("\nTable 2 over {} seeds — map error [m], mean ± sd (sample, n − 1)\n", report.seeds.size());
  s += fmt::format("{:<44} {:>9}   {:>17} {:>17}", "Method", "paper [m]", "paper's set-up", "ATE [m]");
  if (f2m) s += fmt::format("   {:>17} {:>17}", "frame to map", "ATE [m]");
  s += "\n";
  for (const auto& a : report.aggregate) {
    if (a.setup != DemoSetUp::FrameToFrame) continue;
    s += fmt::format("{:<44} {:>9.3f}   {:>17} {:>17}", rowTitle(a.method), paperMapError(a.method),
                     fmt::format("{:.3f} ± {:.3f}", a.map_error_m.mean, a.map_error_m.sd),
                     fmt::format("{:.3f} ± {:.3f}", a.ate_m.mean, a.ate_m.sd));
    for (const auto& b : report.aggregate)
      if (b.setup == DemoSetUp::FrameToMap && b.method == a.method)
        s += fmt::format("   {:>17} {:>17}", fmt::format("{:.3f} ± {:.3f}", b.map_error_m.mean, b.map_error_m.sd),
                         fmt::format("{:.3f} ± {:.3f}", b.ate_m.mean, b.ate_m.sd));
    s += "\n";
  }
  for (const auto& a : report.aggregate)
    if (a.setup == DemoSetUp::CameraLabels)
      s += fmt::format("{:<44} {:>9}   {:>17} {:>17}\n", std::string(toString(a.method)) + ", camera labels", "",
                       fmt::format("{:.3f} ± {:.3f}", a.map_error_m.mean, a.map_error_m.sd),
                       fmt::format("{:.3f} ± {:.3f}", a.ate_m.mean, a.ate_m.sd));
  return s;
}

std::string seedsJson(const SeedsReport& report) {
  nlohmann::json aggregate = nlohmann::json::object();
  for (const auto& a : report.aggregate)
    aggregate[toString(a.setup)][toString(a.method)] = {{"map_error_m", statsJson(a.map_error_m)},
                                                        {"ate_m", statsJson(a.ate_m)},
                                                        {"frames_per_s", statsJson(a.frames_per_s)},
                                                        {"loops", statsJson(a.loops)},
                                                        {"edge_nees_odometry_mean", statsJson(a.nees_odometry)},
                                                        {"edge_nees_loop_mean", statsJson(a.nees_loop)},
                                                        {"paper_map_error_m", paperMapError(a.method)}};
  nlohmann::json per_seed = nlohmann::json::object();
  for (std::size_t k = 0; k < report.per_seed.size(); ++k)
    per_seed[std::to_string(report.seeds[k])] = nlohmann::json::parse(table2Json(report.per_seed[k]));
  return nlohmann::json{{"format", "hazmap-table2-seeds/1"},
                        {"seeds", report.seeds},
                        {"statistics", "mean and sample standard deviation (n - 1) over the seeds"},
                        {"aggregate", aggregate},
                        {"per_seed", per_seed}}
      .dump(2);
}

SeedsReport runDemoSeeds(const DemoConfig& config, const std::vector<std::uint64_t>& seeds, std::ostream& out) {
  const auto t0 = std::chrono::steady_clock::now();
  if (seeds.empty()) fail("--seeds", "no seeds to run");
  SeedsReport report;
  report.seeds = seeds;
  for (std::uint64_t seed : seeds) {
    DemoConfig one = config;
    one.seed = seed;
    one.out_dir = config.out_dir / fmt::format("seed-{}", seed);
    out << fmt::format("\n=== seed {} ({} of {}) → {}\n", seed, report.per_seed.size() + 1, seeds.size(),
                       one.out_dir.string());
    report.per_seed.push_back(runDemo(one, out));
  }
  report.aggregate = aggregateSeeds(report.per_seed);
  report.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  writeTextAtomically(config.out_dir / "table2.json", seedsJson(report) + "\n");
  writeSeedsIndex(config.out_dir, report);
  out << formatSeedsTables(report);
  out << fmt::format("\nWrote {}/table2.json (mean ± sd and every seed's table) index.html and seed-<N>/ per seed in {:.1f} s\n",
                     config.out_dir.string(), report.total_seconds);
  return report;
}

}  // namespace hazmap
