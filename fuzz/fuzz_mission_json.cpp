// libFuzzer target: the missions' JSON readers (issue 34): changes.json (`hazmap view` reads a
// run's or a merge's changes) and a map folder's graph_extras.json (applied to a small graph).
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
  return 0;
}
