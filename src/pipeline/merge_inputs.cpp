// The inputs and the output of `hazmap merge` checked before any work (pipeline/merge_detail.hpp).
#include <fmt/format.h>

#include <system_error>

#include "hazmap/core/error.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/pipeline/slam_method.hpp"
#include "pipeline/merge_detail.hpp"

namespace hazmap::pipeline_detail {

namespace fs = std::filesystem;

namespace {

bool sameFolder(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  return fs::equivalent(a, b, ec);
}

MergeInput openInput(const fs::path& dir) {
  MergeInput in{openMap(dir), {}, {}, {}};
  const std::size_t frames = in.map.manifest().frames;
  in.original = readKittiTrajectory(dir / "trajectory.kitti").poses;
  in.graph = in.map.graph();
  if (in.original.size() != frames)
    fail(dir.string(), fmt::format("trajectory.kitti has {} poses, map.json says {} frames", in.original.size(), frames));
  if (in.graph.numNodes() != static_cast<int>(frames))
    fail(dir.string(), fmt::format("graph.g2o has {} nodes, map.json says {} frames (one node per frame expected)",
                                   in.graph.numNodes(), frames));
  if (in.map.keyframes().empty()) fail(dir.string(), "the map has no keyframes");
  in.poses = in.original;
  return in;
}

}  // namespace

std::vector<MergeInput> openMergeInputs(const std::vector<fs::path>& maps) {
  if (maps.size() < 2) fail("merge", "needs at least two map folders");
  for (std::size_t i = 0; i < maps.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (sameFolder(maps[i], maps[j]))
        fail(maps[i].string(), "is given twice (the same folder as " + maps[j].string() + ")");
  std::vector<MergeInput> inputs;
  for (const auto& dir : maps) {
    inputs.push_back(openInput(dir));
    // Another class table would give the same ids other meanings: refused, as for --prior.
    if (inputs.size() > 1) checkPriorClasses(inputs.back().map, inputs.front().map.classes());
  }
  return inputs;
}

SlamConfig mergeConfig(const MapFolder& first, int threads) {
  const MapManifest& m = first.manifest();
  SlamConfig config = SlamConfig::forMethod(parseSlamMethod(m.method.empty() ? "property-icp+pgo" : m.method));
  try {
    config.applyYamlString(m.parameters_json, (first.dir() / "map.json").string() + " parameters");
  } catch (const Error& e) {
    fail((first.dir() / "map.json").string(), std::string("parameters cannot be read back: ") + e.what());
  }
  config.threads = threads;
  return config;
}

bool checkMergeOutput(const fs::path& out, const std::vector<fs::path>& maps, bool overwrite) {
  for (const auto& m : maps)
    if (sameFolder(out, m)) fail("--out", out.string() + " is one of the maps to merge; write the merge elsewhere");
  std::error_code ec;
  if (!fs::exists(out, ec)) return false;
  if (!fs::is_directory(out, ec)) fail(out.string(), "exists and is not a folder");
  if (fs::is_empty(out, ec)) return true;
  if (!overwrite) fail(out.string(), "exists and is not empty (pass --overwrite to replace it)");
  // Only ever replace a previous map (a merge or a run), never an arbitrary folder.
  if (!fs::exists(out / "map.json", ec)) fail(out.string(), "exists, is not empty and is not a map folder; refusing to replace it");
  return true;
}

}  // namespace hazmap::pipeline_detail
