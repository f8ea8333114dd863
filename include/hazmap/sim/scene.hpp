#pragma once
// The simulated world: a triangle mesh (the building, ray-cast by the LiDAR model), property
// regions (volumes; a LiDAR return whose surface point lies inside one takes its class, as when
// a thermal/NIR camera's detection is projected onto the point cloud) and the robot's route.
//
// Built-in scenes (see docs/simulator.md for maps):
//   naraha    the paper's experiment: 40 m x 24 m hall, 5 m walls, six identical tanks, two
//             identical staircases, 0.6 m pillars every 8 m, a featureless 20 m x 3 m corridor,
//             3 heat sources and 3 puddles placed asymmetrically; ~120 m closed loop + a repeat.
//   corridor  a 60 m x 3 m featureless corridor (degenerate along its axis) with a few patches.
//   tanks     an open field of twelve identical tanks with a few patches.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/ply.hpp"

namespace hazmap::sim {

/// A volume that gives its class to the surface points inside it.
struct PropertyRegion {
  enum class Shape { Box, Polygon };
  std::string name;
  ClassId class_id = 0;
  Shape shape = Shape::Box;
  Eigen::Vector3d box_min = Eigen::Vector3d::Zero();  ///< Box: axis-aligned corners (m)
  Eigen::Vector3d box_max = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> polygon;  ///< Polygon: simple polygon in the xy plane (m)
  double z_min = 0.0, z_max = 0.0;       ///< Polygon: vertical extent of the prism (m)
  /// Added to TemperatureConfig::hot_c on a heat region's surfaces (°C): a source hotter in a
  /// later mission (sim/missions.hpp). Not read from or written to regions YAML.
  double temperature_offset_c = 0.0;

  static PropertyRegion box(std::string name, ClassId id, const Eigen::Vector3d& min,
                            const Eigen::Vector3d& max);
  static PropertyRegion prism(std::string name, ClassId id, std::vector<Eigen::Vector2d> polygon,
                              double z_min, double z_max);

  bool contains(const Eigen::Vector3d& p) const;
  /// Axis-aligned bounds of the volume.
  Eigen::Vector3d boundsMin() const;
  Eigen::Vector3d boundsMax() const;
};

/// The robot's path on the floor: straight legs between waypoints, corners rounded with arcs of
/// `corner_radius` (shrunk to fit short legs); corners turning more than 135° (or any corner when
/// corner_radius is 0) are turned on the spot, as a crawler does.
struct Route {
  std::vector<Eigen::Vector2d> waypoints;
  double corner_radius = 2.0;  ///< m
  double floor_z = 0.0;        ///< height of the floor the robot drives on (m)
  /// Number of leading waypoints that form the closed loop (the last of them equals the first);
  /// 0 when the route has no designated loop. Waypoints after it repeat part of the loop.
  std::size_t loop_waypoints = 0;
  /// Length of the polyline through the waypoints (corners not rounded), m.
  double polylineLength() const;
};

struct Scene {
  std::string name;
  TriangleMesh mesh;  ///< triangle_classes filled by labelTriangles()
  std::vector<PropertyRegion> regions;
  Route route;

  /// Class of a surface point: the first region containing it, else 0 (none).
  ClassId classAt(const Eigen::Vector3d& p) const;
  /// The first region containing `p`, or null.
  const PropertyRegion* regionAt(const Eigen::Vector3d& p) const;
  /// Gives each triangle the class of the region that contains its centroid (for scene.ply).
  void labelTriangles();
  /// Property classes the regions use (sorted, unique).
  std::vector<ClassId> regionClasses() const;
  /// Throws hazmap::Error naming `where` for an empty mesh, an out-of-range triangle index, a
  /// non-finite vertex, a region whose class is not in `table`, or a route with < 2 waypoints.
  void validate(const ClassTable& table, const std::string& where) const;
};

/// Names of the built-in scenes.
std::vector<std::string> builtinSceneNames();
/// Throws hazmap::Error("scenario: unknown scenario 'x' (known: ...)") for an unknown name.
Scene builtinScene(const std::string& name);

/// Reads a user scene: mesh from a PLY file, regions (and the route) from YAML:
///   regions:
///     - {name: heater, class: heat, box: {min: [x, y, z], max: [x, y, z]}}
///     - {name: puddle, class: water, polygon: [[x, y], ...], z: [z_min, z_max]}
///   route: {waypoints: [[x, y], ...], corner_radius: 2.0, floor_z: 0.0}
/// `class` is a class name or id of `table`. Errors name the file and the entry.
Scene loadScene(const std::filesystem::path& mesh_ply, const std::filesystem::path& regions_yaml,
                const ClassTable& table);
/// The scene's regions and route in the format loadScene() reads (class names from `table`,
/// numbers written so they read back exactly): with scene.ply it reproduces the scene.
std::string regionsToYaml(const Scene& scene, const ClassTable& table);
/// Parses only the regions/route YAML text (`where` names it in errors).
void parseRegionsYaml(const std::string& yaml, const std::string& where, const ClassTable& table,
                      Scene& scene);

}  // namespace hazmap::sim
