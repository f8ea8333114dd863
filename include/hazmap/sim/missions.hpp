#pragma once
// Simulated missions (issue 34, part 5): the same site entered again. Mission 1 is the built-in
// scene with a crate standing in it and the whole route. A later mission K starts elsewhere on
// the route (the robot is not told where), drives part of it, and finds the scene changed in
// ways recorded as truth (changes_truth.json): a heat source moved 2 m, one hazard removed, one
// heat source hotter, a new puddle, and the crate moved (geometry without a hazard).
// Its poses.txt is in mission 1's frame (mission 1's first scan), so a run localised in mission
// 1's map can be scored directly; its odometry.txt too (a run with --prior ignores both starts).
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "hazmap/sim/scene.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

/// One change of the scene against mission 1 (positions in the scene's frame).
struct SceneChange {
  /// moved | removed | new | value_changed | geometry_moved
  std::string kind;
  std::string name;       ///< the region (or "crate")
  ClassId class_id = 0;   ///< 0 for geometry
  Eigen::Vector3d before = Eigen::Vector3d::Zero();  ///< centre in mission 1 (new: = after)
  Eigen::Vector3d after = Eigen::Vector3d::Zero();   ///< centre now (removed: = before)
  double temperature_before_c = 0.0, temperature_after_c = 0.0;  ///< value_changed
};

struct MissionPlan {
  int mission = 1;
  Scene scene;  ///< as the mission finds it, with the mission's route
  std::vector<SceneChange> changes;  ///< against mission 1; empty for mission 1
  /// Mission 1's first sensor pose in the scene (world ← mission 1's first scan).
  Eigen::Isometry3d mission1_origin = Eigen::Isometry3d::Identity();
};

/// The plan of mission `mission` (>= 1) over built-in scene `base` (naraha, tanks, corridor);
/// `seed` varies where a later mission starts. Throws hazmap::Error for mission < 1 or a scene
/// without a mission set-up (a user scene).
MissionPlan planMission(const Scene& base, int mission, std::uint64_t seed, const SimulatorConfig& config);

/// changes_truth.json: {"mission", "scene", "frame", "changes": [{kind, name, class, before[3],
/// after[3], distance_m, temperature_before_c, temperature_after_c}]}, positions in mission 1's
/// frame.
std::string changesTruthJson(const MissionPlan& plan, const ClassTable& table);

/// Writes mission `plan` as a sequence folder (writeSimulation) with changes_truth.json.
SimulationSummary writeMission(const SimulatorConfig& config, const MissionPlan& plan,
                               const std::filesystem::path& out_dir, bool overwrite);

}  // namespace hazmap::sim
