#pragma once
// Synthetic property scenes for the loop-closure tests: rectangular property patches (heat on
// walls, water on the floor) sampled as points, observed from sensor poses within a range.
#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/loop/candidates.hpp"

namespace hazmap::test {

struct Patch {
  ClassId cls;
  Eigen::Vector3d center;
  Eigen::Vector3d u, v;  ///< half-size edge vectors
  float value = 20.0f;
};

inline Patch floorPatch(ClassId c, double x, double y, double hx, double hy, float value = 15.f) {
  return {c, {x, y, 0.0}, {hx, 0, 0}, {0, hy, 0}, value};
}
inline Patch wallPatch(ClassId c, double x, double y, double z, double half, double yaw, float value = 80.f) {
  const Eigen::Vector3d along(std::cos(yaw) * half, std::sin(yaw) * half, 0.0);
  return {c, {x, y, z}, along, {0, 0, half}, value};
}

/// Points of the patches in the world frame, on a grid of `step` (m).
inline LabeledCloud samplePatches(const std::vector<Patch>& patches, double step = 0.1) {
  LabeledCloud cloud;
  cloud.enableProperty();
  for (const auto& p : patches) {
    const int nu = std::max(1, static_cast<int>(2 * p.u.norm() / step));
    const int nv = std::max(1, static_cast<int>(2 * p.v.norm() / step));
    for (int i = 0; i <= nu; ++i)
      for (int j = 0; j <= nv; ++j) {
        const Eigen::Vector3d x = p.center + p.u * (2.0 * i / nu - 1.0) + p.v * (2.0 * j / nv - 1.0);
        cloud.push_back(x.cast<float>(), p.cls, 0.f, 0.0, p.value);
      }
  }
  return cloud;
}

/// The part of `world` within `range` of the sensor, in the sensor frame, with Gaussian noise
/// and a random dropout fraction.
inline LabeledCloud observe(const LabeledCloud& world, const Eigen::Isometry3d& T_world_sensor,
                            double range, double noise, double dropout, std::mt19937& rng) {
  std::normal_distribution<float> n(0.f, static_cast<float>(noise));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::Isometry3d T_sensor_world = T_world_sensor.inverse();
  LabeledCloud out = LabeledCloud::withLayoutOf(world);
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector3d p = T_sensor_world * world.points[i].cast<double>();
    if (p.norm() > range || u(rng) < dropout) continue;
    const Eigen::Vector3f q = p.cast<float>() + Eigen::Vector3f(n(rng), n(rng), n(rng));
    out.push_back(q, world.classes[i], 0.f, 0.0, world.property.empty() ? 0.f : world.property[i]);
  }
  return out;
}

/// A rectangular route 20 m × 10 m driven counter-clockwise from the origin, one keyframe per
/// metre (61 keyframes; the last one is back at the start), sensor 0.5 m above the floor.
inline PoseList rectangleRoute() {
  PoseList poses;
  const Eigen::Vector2d corners[] = {{0, 0}, {20, 0}, {20, 10}, {0, 10}, {0, 0}};
  for (int s = 0; s < 4; ++s) {
    const Eigen::Vector2d a = corners[s], b = corners[s + 1];
    const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
    const int n = static_cast<int>(std::round((b - a).norm()));
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(k) / n);
      poses.push_back(fromXyzRpy(p.x(), p.y(), 0.5, 0, 0, yaw));
    }
  }
  poses.push_back(fromXyzRpy(0.2, -0.3, 0.5, 0, 0, 0.15));  // back near the start
  return poses;
}

/// The route as a drifting odometry would report it: each step's length × (1 + scale_error),
/// plus a yaw bias per step, composed from the first pose.
inline PoseList driftedRoute(const PoseList& truth, double scale_error, double yaw_bias_per_step) {
  PoseList est{truth.front()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    Eigen::Isometry3d step = truth[i - 1].inverse() * truth[i];
    step.translation() *= 1.0 + scale_error;
    step = fromXyzRpy(0, 0, 0, 0, 0, yaw_bias_per_step) * step;
    est.push_back(normalized(est.back() * step));
  }
  return est;
}

/// Property patches along the rectangle route: 2–6 visible within 10 m from any keyframe,
/// placed irregularly (no symmetric arrangement).
inline std::vector<Patch> routePatches() {
  return {
      floorPatch(2, 2.0, -2.2, 0.8, 0.5),     wallPatch(1, -2.5, 1.0, 1.2, 0.4, 1.57),
      wallPatch(1, 4.5, 3.2, 1.0, 0.5, 0.0),  floorPatch(2, 7.0, -1.5, 0.6, 0.9),
      floorPatch(2, 10.5, 2.5, 1.0, 0.6),     wallPatch(1, 12.5, -2.5, 1.5, 0.4, 0.0),
      floorPatch(2, 17.5, 4.0, 0.7, 0.7),     wallPatch(1, 22.5, 7.5, 1.0, 0.5, 1.57),
      floorPatch(2, 15.0, 12.0, 1.2, 0.5),    wallPatch(1, 8.0, 12.5, 1.4, 0.4, 0.0),
      floorPatch(2, 3.0, 7.5, 0.8, 0.8),      wallPatch(1, -2.5, 6.0, 1.2, 0.5, 1.57),
      wallPatch(1, 16.0, -2.5, 0.9, 0.4, 0.0),
  };
}

}  // namespace hazmap::test
