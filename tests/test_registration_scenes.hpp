#pragma once
// Synthetic scenes for the registration and odometry tests: surfaces sampled at random with
// Gaussian noise, some patches carrying property classes (1 heat, 2 water, 3 radiation).
#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap::test {

/// A rectangle: origin corner + two edge vectors; class for points on it.
struct Patch {
  Eigen::Vector3d origin, u, v;
  ClassId cls = 0;
};

/// Room-like scene: floor, ceiling, walls and a few boxes (well constrained in all six directions),
/// with heat/water/radiation patches.
inline std::vector<Patch> roomScene() {
  using V = Eigen::Vector3d;
  std::vector<Patch> s;
  s.push_back({V(-10, -6, 0), V(20, 0, 0), V(0, 12, 0), 0});   // floor
  s.push_back({V(-10, -6, 4), V(20, 0, 0), V(0, 12, 0), 0});   // ceiling
  s.push_back({V(-10, -6, 0), V(20, 0, 0), V(0, 0, 4), 0});    // wall y=-6
  s.push_back({V(-10, 6, 0), V(20, 0, 0), V(0, 0, 4), 0});     // wall y=6
  s.push_back({V(-10, -6, 0), V(0, 12, 0), V(0, 0, 4), 0});    // wall x=-10
  s.push_back({V(10, -6, 0), V(0, 12, 0), V(0, 0, 4), 0});     // wall x=10
  // two boxes (their sides break the symmetry)
  for (const V& c : {V(3, 2, 0), V(-4, -3, 0)}) {
    const double a = 1.5, h = 1.2;
    s.push_back({c, V(a, 0, 0), V(0, 0, h), 0});
    s.push_back({c + V(0, a, 0), V(a, 0, 0), V(0, 0, h), 0});
    s.push_back({c, V(0, a, 0), V(0, 0, h), 0});
    s.push_back({c + V(a, 0, 0), V(0, a, 0), V(0, 0, h), 0});
    s.push_back({c + V(0, 0, h), V(a, 0, 0), V(0, a, 0), 0});
  }
  // property patches (drawn on top of surfaces, slightly offset to be their own samples)
  s.push_back({V(-2, -5.99, 1), V(1, 0, 0), V(0, 0, 1), 1});  // heat on a wall
  s.push_back({V(6, 5.99, 0.5), V(0.8, 0, 0), V(0, 0, 0.8), 1});
  s.push_back({V(1, -1, 0.01), V(2, 0, 0), V(0, 1.5, 0), 2});  // puddle
  s.push_back({V(9.99, -1, 2), V(0, 0.7, 0), V(0, 0, 0.7), 3});  // radiation
  return s;
}

/// Long corridor along x: floor, ceiling, two walls, nothing that fixes x (degenerate), and
/// property patches every `spacing` m on the walls (they alone fix x).
inline std::vector<Patch> corridorScene(double length = 40.0, bool with_patches = true,
                                        double spacing = 7.0) {
  using V = Eigen::Vector3d;
  std::vector<Patch> s;
  const double x0 = -length / 2;
  s.push_back({V(x0, -1.5, 0), V(length, 0, 0), V(0, 3, 0), 0});
  s.push_back({V(x0, -1.5, 3), V(length, 0, 0), V(0, 3, 0), 0});
  s.push_back({V(x0, -1.5, 0), V(length, 0, 0), V(0, 0, 3), 0});
  s.push_back({V(x0, 1.5, 0), V(length, 0, 0), V(0, 0, 3), 0});
  if (with_patches) {
    int k = 0;
    for (double x = x0 + 3.0; x < -x0 - 1.0; x += spacing, ++k) {
      const double y = (k % 2 == 0) ? -1.49 : 1.49;
      s.push_back({V(x, y, 0.8 + 0.3 * (k % 3)), V(0.6, 0, 0), V(0, 0, 0.6), ClassId(1 + k % 2)});
    }
  }
  return s;
}

/// An open field seen from a low sensor: a 30 m square of floor (`floor_points`, noise
/// `floor_sigma` along z) and six round pillars (radius 1 m, 3 m high, 4 m apart; `pillar_points`
/// each, radial noise `pillar_sigma`), placed with `T`. A floor seen at grazing angles is flat to
/// millimetres while sparse pillars fit their local planes to centimetres.
inline LabeledCloud pillarField(std::size_t floor_points, double floor_sigma, std::size_t pillar_points,
                                double pillar_sigma, std::mt19937& rng,
                                const Eigen::Isometry3d& T = Eigen::Isometry3d::Identity()) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> floor_noise(0.0, floor_sigma), pillar_noise(0.0, pillar_sigma);
  LabeledCloud c;
  const auto add = [&](const Eigen::Vector3d& p) { c.push_back((T * p).cast<float>(), 0); };
  for (std::size_t k = 0; k < floor_points; ++k) add({30.0 * u(rng) - 15.0, 30.0 * u(rng) - 15.0, floor_noise(rng)});
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j)
      for (std::size_t k = 0; k < pillar_points; ++k) {
        const double a = 2.0 * M_PI * u(rng), r = 1.0 + pillar_noise(rng);
        add({4.0 * i - 4.0 + r * std::cos(a), 4.0 * j - 2.0 + r * std::sin(a), 3.0 * u(rng)});
      }
  return c;
}

/// Samples `n` points over the patches (proportional to area), then applies `T` and adds noise.
inline LabeledCloud samplePatches(const std::vector<Patch>& patches, std::size_t n, std::mt19937& rng,
                                  double noise_sigma = 0.0,
                                  const Eigen::Isometry3d& T = Eigen::Isometry3d::Identity(),
                                  double property_density = 4.0) {
  std::vector<double> area;
  double total = 0;
  for (const auto& p : patches) {
    // property patches are sampled denser, like a co-mounted camera labelling many returns
    const double a = p.u.cross(p.v).norm() * (p.cls != 0 ? property_density : 1.0);
    area.push_back(a);
    total += a;
  }
  std::discrete_distribution<std::size_t> pick(area.begin(), area.end());
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  LabeledCloud cloud;
  cloud.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Patch& p = patches[pick(rng)];
    Eigen::Vector3d x = p.origin + uni(rng) * p.u + uni(rng) * p.v;
    x = T * x;
    if (noise_sigma > 0) x += noise_sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    cloud.push_back(x.cast<float>(), p.cls);
  }
  return cloud;
}

}  // namespace hazmap::test
