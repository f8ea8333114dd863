// Simulated missions (include/hazmap/sim/missions.hpp): per built-in scene, where the crate
// stands, which sources move, vanish or heat up, where a puddle appears; and which part of the
// route a later mission drives.
#include "hazmap/sim/missions.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/sim/mesh_builder.hpp"

namespace hazmap::sim {

namespace {

using V2 = Eigen::Vector2d;
using V3 = Eigen::Vector3d;

// What changes in one built-in scene between mission 1 and the later missions.
struct MissionEdits {
  std::string moved;       ///< heat source moved by move_by (with its geometry, if it has any)
  V3 move_by = V3::Zero();
  std::string removed;     ///< region removed with its geometry
  std::string hotter;      ///< heat source hotter by hotter_by_c
  double hotter_by_c = 40.0;
  std::vector<V2> new_puddle;
  V3 crate_min, crate_max;  ///< mission 1's crate (1 m, no hazard)
  V3 crate_move_by = V3::Zero();
};

// Places chosen on free floor, within a few metres of the route (so a mission that drives past
// sees them), clear of walls, tanks and pillars.
MissionEdits editsFor(const std::string& scene) {
  MissionEdits e;
  if (scene == "naraha") {
    e.moved = "heat_machine", e.move_by = V3(0.0, 2.0, 0.0);
    e.removed = "heat_corridor_panel";
    e.hotter = "heat_tank_patch";
    e.new_puddle = {{15.0, 10.9}, {16.0, 10.8}, {16.4, 11.5}, {15.8, 12.0}, {15.1, 11.7}};
    e.crate_min = V3(20.0, 10.8, 0.0), e.crate_max = V3(21.0, 11.8, 1.0);
    e.crate_move_by = V3(3.0, -0.5, 0.0);
  } else if (scene == "tanks") {
    e.moved = "heat_box", e.move_by = V3(0.0, -2.0, 0.0);
    e.removed = "water";
    e.hotter = "heat_tank_patch";
    e.new_puddle = {{9.4, 10.2}, {10.4, 10.1}, {10.7, 10.9}, {10.1, 11.2}, {9.5, 10.9}};
    e.crate_min = V3(1.5, 13.8, 0.0), e.crate_max = V3(2.5, 14.8, 1.0);
    e.crate_move_by = V3(4.0, 0.0, 0.0);
  } else if (scene == "corridor") {
    e.moved = "heat_panel_north", e.move_by = V3(2.0, 0.0, 0.0);
    e.removed = "water_b";
    e.hotter = "heat_panel_south";
    e.new_puddle = {{36.0, -0.6}, {37.1, -0.7}, {37.3, 0.2}, {36.4, 0.5}, {35.9, 0.0}};
    e.crate_min = V3(10.0, 0.5, 0.0), e.crate_max = V3(10.8, 1.3, 0.8);
    e.crate_move_by = V3(14.0, -1.6, 0.0);
  } else {
    fail("--mission", "scene '" + scene + "' has no mission set-up (built-in: naraha, tanks, corridor)");
  }
  return e;
}

PropertyRegion& regionNamed(Scene& s, const std::string& name) {
  for (auto& r : s.regions)
    if (r.name == name) return r;
  fail("--mission", "scene " + s.name + " has no region '" + name + "'");
}

V3 centreOf(const PropertyRegion& r) { return 0.5 * (r.boundsMin() + r.boundsMax()); }

// Triangles lying wholly inside the region's bounds (1 cm slack): the source's own geometry.
std::vector<std::size_t> trianglesInside(const Scene& s, const PropertyRegion& r) {
  const Eigen::Vector3f lo = (r.boundsMin() - V3::Constant(0.01)).cast<float>();
  const Eigen::Vector3f hi = (r.boundsMax() + V3::Constant(0.01)).cast<float>();
  std::vector<std::size_t> inside;
  for (std::size_t t = 0; t < s.mesh.triangles.size(); ++t) {
    bool all = true;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3f& v = s.mesh.vertices[static_cast<std::size_t>(s.mesh.triangles[t][k])];
      all = all && (v.array() >= lo.array()).all() && (v.array() <= hi.array()).all();
    }
    if (all) inside.push_back(t);
  }
  return inside;
}

void moveRegion(Scene& s, const std::string& name, const V3& by) {
  PropertyRegion& r = regionNamed(s, name);
  for (std::size_t t : trianglesInside(s, r))
    for (int k = 0; k < 3; ++k) {  // fresh vertices: a shared one must not drag a neighbour along
      s.mesh.vertices.push_back(s.mesh.vertices[static_cast<std::size_t>(s.mesh.triangles[t][k])] + by.cast<float>());
      s.mesh.triangles[t][k] = static_cast<int>(s.mesh.vertices.size() - 1);
    }
  r.box_min += by, r.box_max += by;
  for (auto& p : r.polygon) p += by.head<2>();
  r.z_min += by.z(), r.z_max += by.z();
}

void removeRegion(Scene& s, const std::string& name) {
  const std::vector<std::size_t> gone = trianglesInside(s, regionNamed(s, name));
  std::vector<Eigen::Vector3i> kept;
  for (std::size_t t = 0, g = 0; t < s.mesh.triangles.size(); ++t) {
    if (g < gone.size() && gone[g] == t) {
      ++g;
      continue;
    }
    kept.push_back(s.mesh.triangles[t]);
  }
  s.mesh.triangles = std::move(kept);
  std::erase_if(s.regions, [&](const PropertyRegion& r) { return r.name == name; });
}

void addPuddle(Scene& s, const std::string& name, const std::vector<V2>& polygon) {
  MeshBuilder(s.mesh).polygonDecal(polygon, 0.003);
  s.regions.push_back(PropertyRegion::prism(name, 2, polygon, -0.05, 0.05));  // 2 = water (built-in table)
}

// A later mission's route: from waypoint `start` of the closed loop, about 60 % of its legs.
// A route without a loop is driven from its second waypoint on.
Route partialRoute(const Route& full, std::size_t start) {
  Route r = full;
  r.waypoints.clear();
  r.loop_waypoints = 0;
  if (full.loop_waypoints < 3) {  // out and back (corridor): from the far end
    r.waypoints.assign(full.waypoints.begin() + (full.waypoints.size() > 2 ? 1 : 0), full.waypoints.end());
    if (full.waypoints.size() <= 2) std::reverse(r.waypoints.begin(), r.waypoints.end());
    return r;
  }
  const std::size_t n = full.loop_waypoints - 1;  // distinct corners of the loop
  const std::size_t legs = (6 * n + 9) / 10;
  for (std::size_t k = 0; k <= legs; ++k) r.waypoints.push_back(full.waypoints[(start + k) % n]);
  return r;
}

}  // namespace

MissionPlan planMission(const Scene& base, int mission, std::uint64_t seed, const SimulatorConfig& config) {
  if (mission < 1) fail("--mission", "must be 1 or more, got " + std::to_string(mission));
  const MissionEdits e = editsFor(base.name);
  MissionPlan plan;
  plan.mission = mission;
  plan.scene = base;
  plan.mission1_origin = sensorPose(sampleRoute(base.route, config.robot).front(), base.route.floor_z,
                                    config.sensor.mount_height);
  Scene& s = plan.scene;
  if (mission == 1) {
    MeshBuilder(s.mesh).box(e.crate_min, e.crate_max);
    s.labelTriangles();
    return plan;
  }
  MeshBuilder(s.mesh).box(e.crate_min + e.crate_move_by, e.crate_max + e.crate_move_by);
  const TemperatureConfig& t = config.temperature;
  const PropertyRegion moved = regionNamed(s, e.moved), removed = regionNamed(s, e.removed);
  moveRegion(s, e.moved, e.move_by);
  plan.changes.push_back({"moved", e.moved, moved.class_id, centreOf(moved), centreOf(moved) + e.move_by});
  removeRegion(s, e.removed);
  plan.changes.push_back({"removed", e.removed, removed.class_id, centreOf(removed), centreOf(removed)});
  PropertyRegion& hot = regionNamed(s, e.hotter);
  hot.temperature_offset_c = e.hotter_by_c;
  plan.changes.push_back({"value_changed", e.hotter, hot.class_id, centreOf(hot), centreOf(hot), t.hot_c,
                          t.hot_c + e.hotter_by_c});
  addPuddle(s, "water_new", e.new_puddle);
  plan.changes.push_back({"new", "water_new", 2, centreOf(s.regions.back()), centreOf(s.regions.back())});
  const V3 crate = 0.5 * (e.crate_min + e.crate_max);
  plan.changes.push_back({"geometry_moved", "crate", 0, crate, crate + e.crate_move_by});
  const std::size_t loop = std::max<std::size_t>(base.route.loop_waypoints, 2) - 1;
  const std::size_t stride = std::max<std::size_t>(loop / 3, 1);
  s.route = partialRoute(base.route, ((static_cast<std::size_t>(mission) - 1) * stride + seed - 1) % loop);
  s.labelTriangles();
  return plan;
}

std::string changesTruthJson(const MissionPlan& plan, const ClassTable& table) {
  const Eigen::Isometry3d to_frame = plan.mission1_origin.inverse();
  const auto xyz = [&](const V3& p) {
    const V3 q = to_frame * p;
    return nlohmann::json{q.x(), q.y(), q.z()};
  };
  nlohmann::json changes = nlohmann::json::array();
  for (const SceneChange& c : plan.changes) {
    const ClassInfo* info = table.find(c.class_id);
    nlohmann::json j = {{"kind", c.kind}, {"name", c.name}, {"class", c.class_id == 0 || !info ? "none" : info->name},
                        {"hazard", c.class_id != 0}, {"before", xyz(c.before)}, {"after", xyz(c.after)},
                        {"distance_m", (c.after - c.before).norm()}};
    if (c.kind == "value_changed") {
      j["temperature_before_c"] = c.temperature_before_c;
      j["temperature_after_c"] = c.temperature_after_c;
    }
    changes.push_back(j);
  }
  nlohmann::json j = {{"mission", plan.mission}, {"scene", plan.scene.name},
                      {"frame", "mission 1's first scan (its poses.txt frame); this mission's poses.txt too"},
                      {"changes", changes}};
  return j.dump(2) + "\n";
}

SimulationSummary writeMission(const SimulatorConfig& config, const MissionPlan& plan,
                               const std::filesystem::path& out_dir, bool overwrite) {
  const ClassTable table = ClassTable::load(config.class_table);
  const Simulator sim(config, plan.scene, table, plan.mission1_origin);
  return writeSimulation(sim, out_dir, overwrite, [&](const std::filesystem::path& folder) {
    writeTextAtomically(folder / "changes_truth.json", changesTruthJson(plan, table));
  });
}

}  // namespace hazmap::sim
