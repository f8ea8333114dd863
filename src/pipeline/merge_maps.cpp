// hazmap merge (pipeline/merge_maps.hpp): inputs checked, maps placed in one graph, the merged
// folder written into a temporary sibling and moved into place at the end.
#include "hazmap/pipeline/merge_maps.hpp"

#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/temporary_folder.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/merge_detail.hpp"

namespace hazmap {

using namespace pipeline_detail;

MergeReport mergeMaps(const std::vector<std::filesystem::path>& maps, const std::filesystem::path& out,
                      const MergeOptions& options) {
  const auto t0 = Clock::now();
  std::vector<MergeInput> inputs = openMergeInputs(maps);
  const bool replace = checkMergeOutput(out, maps, options.overwrite);
  const SlamConfig config = mergeConfig(inputs[0].map, options.threads);
  // The property classes as the first map's runs used them in property ICP.
  const ClassTable classes = config.property_icp.applyTo(inputs[0].map.classes(), inputs[0].map.dir().string());
  MergeReport report;
  const PoseGraph graph = placeMaps(inputs, classes, config, report);
  TemporaryFolder tmp{temporarySibling(out)};
  std::filesystem::create_directories(tmp.path);
  writeMergedFolder(tmp.path, inputs, graph, classes, options, report);
  measureMergeMapError(inputs, report);
  report.seconds = secondsSince(t0);
  writeTextAtomically(tmp.path / "merge.json", mergeJson(report));
  commitFolder(tmp, out, out.string(), replace);
  return report;
}

}  // namespace hazmap
