#include "hazmap/sim/route.hpp"

#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double wrapAngle(double a) {
  while (a > M_PI) a -= 2.0 * M_PI;
  while (a <= -M_PI) a += 2.0 * M_PI;
  return a;
}

/// One piece of the path, parametrised by u in [0, length_u]: straight (u = metres), arc
/// (u = radians, radius r) or a turn on the spot (u = radians).
struct Piece {
  enum Kind { Straight, Arc, Spin } kind;
  Eigen::Vector2d start;  ///< position at u = 0
  double yaw0;            ///< heading at u = 0
  double length_u;
  double radius = 0.0;    ///< Arc
  double sign = 1.0;      ///< Arc/Spin: +1 counter-clockwise (left), -1 clockwise
  double dDistance() const { return kind == Straight ? 1.0 : kind == Arc ? radius : 0.0; }
  double dTurn() const { return kind == Straight ? 0.0 : 1.0; }
  void at(double u, double& x, double& y, double& yaw) const {
    if (kind == Straight) {
      x = start.x() + u * std::cos(yaw0);
      y = start.y() + u * std::sin(yaw0);
      yaw = yaw0;
    } else if (kind == Spin) {
      x = start.x();
      y = start.y();
      yaw = wrapAngle(yaw0 + sign * u);
    } else {
      // Centre of the arc lies to the left (sign +1) or right (sign -1) of the heading.
      const Eigen::Vector2d normal(-std::sin(yaw0), std::cos(yaw0));
      const Eigen::Vector2d center = start + sign * radius * normal;
      const double phi0 = std::atan2(start.y() - center.y(), start.x() - center.x());
      const double phi = phi0 + sign * u;
      x = center.x() + radius * std::cos(phi);
      y = center.y() + radius * std::sin(phi);
      yaw = wrapAngle(yaw0 + sign * u);
    }
  }
};

std::vector<Piece> buildPieces(const Route& route, bool closed) {
  const auto& w = route.waypoints;
  const std::size_t n = w.size();
  std::vector<Eigen::Vector2d> dir(n - 1);
  std::vector<double> len(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    len[i] = (w[i + 1] - w[i]).norm();
    dir[i] = (w[i + 1] - w[i]) / len[i];
  }
  // Tangent length used by the corner at waypoint i (1..n-2), and its arc radius.
  std::vector<double> cut(n, 0.0), radius(n, 0.0), turn(n, 0.0);
  for (std::size_t i = 1; i + 1 < n; ++i) {
    const double a0 = std::atan2(dir[i - 1].y(), dir[i - 1].x());
    const double a1 = std::atan2(dir[i].y(), dir[i].x());
    turn[i] = wrapAngle(a1 - a0);
    const double abs_turn = std::abs(turn[i]);
    if (abs_turn < 1e-9 || abs_turn > 0.75 * M_PI || route.corner_radius <= 0.0) continue;
    const double t = std::tan(abs_turn / 2.0);
    // An arc may use at most half of each adjacent leg.
    const double r = std::min(route.corner_radius, 0.5 * std::min(len[i - 1], len[i]) / t);
    radius[i] = r;
    cut[i] = r * t;
  }
  std::vector<Piece> pieces;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double yaw = std::atan2(dir[i].y(), dir[i].x());
    const double straight = len[i] - cut[i] - cut[i + 1];
    if (straight > 1e-9) pieces.push_back({Piece::Straight, w[i] + cut[i] * dir[i], yaw, straight});
    const std::size_t c = i + 1;  // corner at the end of this leg
    if (c + 1 >= n || std::abs(turn[c]) < 1e-9) continue;
    const double sign = turn[c] > 0 ? 1.0 : -1.0;
    if (radius[c] > 0.0)
      pieces.push_back({Piece::Arc, w[c] - cut[c] * dir[i], yaw, std::abs(turn[c]), radius[c], sign});
    else
      pieces.push_back({Piece::Spin, w[c], yaw, std::abs(turn[c]), 0.0, sign});
  }
  if (!closed) return pieces;
  // Back to the start heading on the spot, so the next drive round starts as this one did.
  const double end_yaw = std::atan2(dir[n - 2].y(), dir[n - 2].x());
  const double back = wrapAngle(std::atan2(dir[0].y(), dir[0].x()) - end_yaw);
  if (std::abs(back) > 1e-9) pieces.push_back({Piece::Spin, w[n - 1], end_yaw, std::abs(back), 0.0, back > 0 ? 1.0 : -1.0});
  return pieces;
}

}  // namespace

std::vector<RouteSample> sampleRoute(const Route& route, const RobotConfig& robot, bool closed) {
  if (route.waypoints.size() < 2) fail("route", "needs at least 2 waypoints");
  for (std::size_t i = 1; i < route.waypoints.size(); ++i)
    if ((route.waypoints[i] - route.waypoints[i - 1]).norm() < 1e-6)
      fail("route", "waypoints " + std::to_string(i - 1) + " and " + std::to_string(i) + " coincide");
  if (!(robot.frame_distance > 0.0) || !(robot.frame_turn_deg > 0.0) || !(robot.max_speed > 0.0) ||
      !(robot.turn_rate_deg > 0.0))
    fail("robot", "frame_distance, frame_turn_deg, max_speed and turn_rate_deg must be > 0");
  if (closed && (route.waypoints.front() - route.waypoints.back()).norm() > 1e-6)
    fail("route", "a closed route must end at its first waypoint");
  const std::vector<Piece> pieces = buildPieces(route, closed);
  const double D = robot.frame_distance;
  const double A = robot.frame_turn_deg * M_PI / 180.0;
  const double speed = robot.max_speed;
  const double turn_rate = robot.turn_rate_deg * M_PI / 180.0;

  std::vector<RouteSample> samples;
  RouteSample cur;
  pieces.front().at(0.0, cur.x, cur.y, cur.yaw);
  samples.push_back(cur);
  double d_since = 0.0, a_since = 0.0;
  for (const Piece& p : pieces) {
    const double dd = p.dDistance(), da = p.dTurn();
    // Time per unit of u: distance at max_speed; spins at turn_rate.
    const double dt = dd > 0.0 ? dd / speed : da / turn_rate;
    double u = 0.0;
    for (;;) {
      const double need_d = dd > 0.0 ? (D - d_since) / dd : kInf;
      const double need_a = da > 0.0 ? (A - a_since) / da : kInf;
      const double step = std::max(0.0, std::min(need_d, need_a));
      if (u + step > p.length_u + 1e-9) {
        const double rest = p.length_u - u;
        d_since += rest * dd;
        a_since += rest * da;
        cur.travelled += rest * dd;
        cur.turned += rest * da;
        cur.time += rest * dt;
        break;
      }
      u += step;
      cur.travelled += step * dd;
      cur.turned += step * da;
      cur.time += step * dt;
      p.at(u, cur.x, cur.y, cur.yaw);
      samples.push_back(cur);
      d_since = a_since = 0.0;
    }
  }
  // The end of the route, unless a scan was taken (almost) there already, or it is the start.
  if (closed) {
    const RouteSample& first = samples.front();
    if (samples.size() > 1 && std::hypot(samples.back().x - first.x, samples.back().y - first.y) < 1e-6 &&
        std::abs(wrapAngle(samples.back().yaw - first.yaw)) < 1e-6)
      samples.pop_back();
    return samples;
  }
  if (d_since > 0.05 * D || a_since > 0.05 * A) {
    const Piece& last = pieces.back();
    last.at(last.length_u, cur.x, cur.y, cur.yaw);
    samples.push_back(cur);
  }
  return samples;
}

Route closedLoop(const Route& route, const std::string& where) {
  Route loop = route;
  loop.loop_waypoints = 0;
  const auto& w = route.waypoints;
  if (route.loop_waypoints >= 3) {
    loop.waypoints.assign(w.begin(), w.begin() + static_cast<std::ptrdiff_t>(route.loop_waypoints));
  } else if (w.size() < 2 || (w.front() - w.back()).norm() > 1e-6) {
    fail(where, "the route has no closed loop (loop_waypoints, or a last waypoint equal to the first)");
  }
  if ((loop.waypoints.front() - loop.waypoints.back()).norm() > 1e-6)
    fail(where, "the route's loop (its first loop_waypoints waypoints) does not end at its first waypoint");
  return loop;
}

Eigen::Isometry3d sensorPose(const RouteSample& s, double floor_z, double mount_height) {
  Eigen::Isometry3d T = fromXyYaw(s.x, s.y, s.yaw);
  T.translation().z() = floor_z + mount_height;
  return T;
}

}  // namespace hazmap::sim
