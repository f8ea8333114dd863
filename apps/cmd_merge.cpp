// hazmap merge MAP_A MAP_B … --out MERGED: one map of several missions (issue 34, part 3;
// pipeline/merge_maps.hpp).
#include <iostream>
#include <memory>

#include "command.hpp"
#include "hazmap/pipeline/merge_maps.hpp"

namespace hazmap::cli {
namespace {

struct MergeArgs {
  std::vector<std::string> maps;
  std::string out;
  MergeOptions options;
  bool no_viewer = false;
  bool quiet = false;
};

void merge(const MergeArgs& a) {
  MergeOptions options = a.options;
  options.write_viewer = !a.no_viewer;
  const std::vector<std::filesystem::path> maps(a.maps.begin(), a.maps.end());
  const MergeReport report = mergeMaps(maps, a.out, options);
  if (!a.quiet) std::cout << formatMergeSummary(report, a.out);
}

const RegisterCommand registration{{
    "merge",
    "Merge the maps of several missions (map folders of hazmap run) into one map folder in the first map's frame",
    [](CLI::App& app) {
      auto a = std::make_shared<MergeArgs>();
      app.add_option("maps", a->maps,
                     "Map folders (each with its map.json); the first is the reference frame, each later one is placed "
                     "in it or reported and left out")
          ->required();
      app.add_option("--out", a->out, "Output map folder (must not exist or be empty, or --overwrite)")->required();
      app.add_flag("--overwrite", a->options.overwrite, "Replace an existing map folder at --out");
      app.add_option("--threads", a->options.threads, "Worker threads (0 = all cores)");
      app.add_flag("--no-viewer", a->no_viewer, "Do not write viewer.html");
      app.add_flag("--quiet", a->quiet, "No summary");
      app.callback([a] { merge(*a); });
    }}};

}  // namespace
}  // namespace hazmap::cli
