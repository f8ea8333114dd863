#pragma once
// The demo's index.html (Table 2 beside links to each method's viewer.html and the figures) and
// its trajectory error plot (each method's error against distance travelled).
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/io/trajectory.hpp"
#include "hazmap/demo/demo.hpp"
#include "hazmap/demo/demo_seeds.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap {

/// The page as a string (links are relative to the demo folder).
std::string demoIndexHtml(const DemoReport& report, bool frame_to_map);
/// Writes <out_dir>/index.html atomically.
void writeDemoIndex(const std::filesystem::path& out_dir, const DemoReport& report, bool frame_to_map);

/// The index.html of a `demo --seeds` folder: Table 2 as mean ± sd over the seeds, the per-seed
/// map errors, and a link to each seed's own index.html.
std::string seedsIndexHtml(const SeedsReport& report);
void writeSeedsIndex(const std::filesystem::path& out_dir, const SeedsReport& report);

/// Writes a PNG of each result's APE (SE(3)-aligned, as the table's ATE) against the distance
/// travelled along `truth`.
void writeMethodErrorPlot(const std::filesystem::path& png, const Trajectory& truth,
                          const std::vector<SlamResult>& results, const std::string& title);

}  // namespace hazmap
