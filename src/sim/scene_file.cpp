// Loading a user scene (kept apart from scene.cpp: it is the only part that needs the PLY reader).
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/sim/scene.hpp"

namespace hazmap::sim {

Scene loadScene(const std::filesystem::path& mesh_ply, const std::filesystem::path& regions_yaml,
                const ClassTable& table) {
  Scene scene;
  scene.name = mesh_ply.stem().string();
  scene.mesh = readPlyMesh(mesh_ply);
  if (scene.mesh.triangles.empty()) fail(mesh_ply.string(), "scene mesh is empty (no triangles)");
  scene.mesh.triangle_classes.clear();
  parseRegionsYaml(readTextFile(regions_yaml), regions_yaml.string(), table, scene);
  if (scene.route.waypoints.empty())
    fail(regions_yaml.string(), "no 'route' given: the robot needs waypoints to drive through");
  scene.validate(table, regions_yaml.string());
  scene.labelTriangles();
  return scene;
}

}  // namespace hazmap::sim
