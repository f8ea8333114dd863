#pragma once
// The crawler driving its route, and when it takes a scan: every `frame_distance` of travel or
// `frame_turn_deg` of turning, whichever comes first (the paper's "large movement per frame").
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "hazmap/sim/scene.hpp"

namespace hazmap::sim {

struct RobotConfig {
  double max_speed = 0.1;         ///< m/s along straight legs and arcs (the paper's crawler)
  double turn_rate_deg = 10.0;    ///< °/s when turning on the spot
  double frame_distance = 1.0;    ///< m of travel between scans
  double frame_turn_deg = 15.0;   ///< ° of turn between scans
};

/// The robot base on the floor when a scan is taken (z = route floor, yaw only).
struct RouteSample {
  double x = 0.0, y = 0.0, yaw = 0.0;
  double time = 0.0;        ///< s since the start, driving at max_speed / turn_rate
  double travelled = 0.0;   ///< m along the path since the start
  double turned = 0.0;      ///< total |yaw change| since the start, rad
};

/// Scan poses along the route: the first at the first waypoint (heading along the first leg),
/// then one at each trigger, and a last one at the end of the route if the robot moved since.
/// Throws hazmap::Error for a route with < 2 waypoints or non-positive trigger settings.
/// `closed` (a route from closedLoop): the route ends where it starts, so the robot turns on the
/// spot at the end to its start heading and the end is not scanned (it is the first scan's pose):
/// the scans then repeat without a jump when driven again and again.
std::vector<RouteSample> sampleRoute(const Route& route, const RobotConfig& robot, bool closed = false);

/// The route's closed loop (SimulatorConfig::closed_route): its first loop_waypoints waypoints,
/// or the whole route when its last waypoint is its first (an out-and-back route). Throws
/// hazmap::Error naming `where` for a route without one.
Route closedLoop(const Route& route, const std::string& where);

/// Sensor pose in the world for a base sample: base at (x, y, floor_z) with yaw, sensor
/// `mount_height` above it, axes aligned with the base (x forward, y left, z up).
Eigen::Isometry3d sensorPose(const RouteSample& s, double floor_z, double mount_height);

}  // namespace hazmap::sim
