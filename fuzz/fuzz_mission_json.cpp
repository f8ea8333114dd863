// libFuzzer target: the missions' JSON readers (issue 34): changes.json (`hazmap view` reads a
// run's or a merge's changes), a map folder's graph_extras.json (applied to a small graph) and
// its map.json (the manifest a `--prior` or a `merge` opens first, before any file of the folder).
#include <cmath>
#include <cstdlib>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/map/hazard_changes.hpp"
#include "map/map_folder_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("mission.json");
  const std::string& path = file.set(data, size);
  try {
    (void)hazmap::readHazardChanges(path);
  } catch (const hazmap::Error&) {
  }
  hazmap::PoseGraph graph;
  for (int i = 0; i < 3; ++i) graph.addNode(Eigen::Isometry3d(Eigen::Translation3d(i, 0, 0)));
  for (int i = 0; i < 2; ++i) graph.addEdge(i, i + 1, Eigen::Isometry3d(Eigen::Translation3d(1, 0, 0)), hazmap::Matrix6d::Identity());
  try {
    hazmap::map_folder_detail::readGraphExtras(path, graph);
    for (const auto& p : graph.gravity_priors)
      if (p.node < 0 || p.node >= graph.numNodes() || !(p.sigma > 0.0)) std::abort();  // addGravityPrior checks
  } catch (const hazmap::Error&) {
  }
  try {
    const auto parsed = hazmap::map_folder_detail::parseMapManifest(std::string(data, data + size), "fuzz-map");
    // What openMap relies on once the manifest parsed: keyframes within the run, every file it
    // names listed, nothing listed outside the folder, an overview voxel that can downsample.
    const auto listed = [&](const std::string& path) {
      for (const auto& f : parsed.files)
        if (f.path == path) return true;
      return false;
    };
    for (const auto& k : parsed.manifest.keyframes)
      if (k.frame >= parsed.manifest.frames || !listed(k.cloud)) std::abort();
    for (const auto& f : parsed.files)
      if (f.path.empty() || f.path.front() == '/' || f.path.find("..") != std::string::npos) std::abort();
    if (!listed(parsed.classes) || !listed(parsed.graph) || !listed(parsed.hazards) || !listed(parsed.trajectory))
      std::abort();
    if (const auto& o = parsed.manifest.search_overview; o && (!(o->voxel > 0.0) || !listed(o->cloud))) std::abort();
  } catch (const hazmap::Error&) {
  }
  return 0;
}
