#pragma once
// Table 2 over seeds (`hazmap demo --seeds 1-8`): the demo once per simulator seed, each into its
// own folder <out>/seed-<N>/ (a complete single-seed demo folder), then mean ± sample standard
// deviation per method and set-up, printed and written to <out>/table2.json (format
// "hazmap-table2-seeds/1": the aggregate plus every seed's single-seed table2.json object).
#include <cstdint>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "hazmap/demo/demo.hpp"

namespace hazmap {

/// "1-8", "1,3,5", "1-3,7" → the seeds in the order given. Throws hazmap::Error naming `where`
/// on an empty list, a non-number, a reversed range, a repeated seed or more than 10,000 seeds.
std::vector<std::uint64_t> parseSeedList(const std::string& text, const std::string& where = "--seeds");

/// Mean, sample standard deviation (n − 1; 0 for one value), min and max.
struct SeedStats {
  std::size_t n = 0;
  double mean = 0.0, sd = 0.0, min = 0.0, max = 0.0;
};
SeedStats seedStats(const std::vector<double>& values);

/// The set-ups of the demo's rows: the paper's (frame to frame), hazmap's frame to local map, and
/// the property methods on camera labels.
enum class DemoSetUp { FrameToFrame, FrameToMap, CameraLabels };
const char* toString(DemoSetUp setup);

/// One method in one set-up over the seeds.
struct SeedAggregateRow {
  DemoSetUp setup = DemoSetUp::FrameToFrame;
  SlamMethod method = SlamMethod::PropertyIcpPgo;
  SeedStats map_error_m, ate_m, frames_per_s, loops;
  SeedStats nees_odometry, nees_loop;  ///< each seed's mean edge NEES (loop: seeds with loop edges)
};

struct SeedsReport {
  std::vector<std::uint64_t> seeds;
  std::vector<DemoReport> per_seed;       ///< in the order of `seeds`
  std::vector<SeedAggregateRow> aggregate;
  double total_seconds = 0.0;
};

/// The aggregate of finished single-seed reports (rows matched by set-up and method).
std::vector<SeedAggregateRow> aggregateSeeds(const std::vector<DemoReport>& reports);

/// Runs the demo for every seed (sequentially; config.seed is ignored), printing each seed's
/// progress and finally the per-seed and the mean ± sd tables to `out`.
SeedsReport runDemoSeeds(const DemoConfig& config, const std::vector<std::uint64_t>& seeds, std::ostream& out);

/// The per-seed map errors (one row per seed, one column per method and set-up) and the
/// mean ± sd table, as text.
std::string formatSeedsTables(const SeedsReport& report);

/// The JSON written to <out>/table2.json by runDemoSeeds.
std::string seedsJson(const SeedsReport& report);

}  // namespace hazmap
