#include "hazmap/sim/mesh_builder.hpp"

#include <cmath>

namespace hazmap::sim {

int MeshBuilder::vertex(const Eigen::Vector3d& p) {
  mesh_.vertices.push_back(p.cast<float>());
  return static_cast<int>(mesh_.vertices.size()) - 1;
}

void MeshBuilder::tri(int a, int b, int c) { mesh_.triangles.emplace_back(a, b, c); }

void MeshBuilder::quad(int a, int b, int c, int d) {
  tri(a, b, c);
  tri(a, c, d);
}

void MeshBuilder::box(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  // Corner k has x from bit 0, y from bit 1, z from bit 2.
  int v[8];
  for (int k = 0; k < 8; ++k)
    v[k] = vertex({(k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z()});
  quad(v[0], v[2], v[3], v[1]);  // bottom (-z)
  quad(v[4], v[5], v[7], v[6]);  // top (+z)
  quad(v[0], v[1], v[5], v[4]);  // -y
  quad(v[2], v[6], v[7], v[3]);  // +y
  quad(v[0], v[4], v[6], v[2]);  // -x
  quad(v[1], v[3], v[7], v[5]);  // +x
}

void MeshBuilder::floorRect(double x0, double y0, double x1, double y1, double z) {
  const int a = vertex({x0, y0, z}), b = vertex({x1, y0, z}), c = vertex({x1, y1, z}),
            d = vertex({x0, y1, z});
  quad(a, b, c, d);
}

void MeshBuilder::cylinder(const Eigen::Vector2d& center, double radius, double z0, double height,
                           int segments, int rings) {
  const double kTwoPi = 2.0 * M_PI;
  std::vector<int> ring_start;
  for (int r = 0; r <= rings; ++r) {
    ring_start.push_back(static_cast<int>(mesh_.vertices.size()));
    const double z = z0 + height * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double a = kTwoPi * s / segments;
      vertex({center.x() + radius * std::cos(a), center.y() + radius * std::sin(a), z});
    }
  }
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const int s1 = (s + 1) % segments;
      quad(ring_start[r] + s, ring_start[r] + s1, ring_start[r + 1] + s1, ring_start[r + 1] + s);
    }
  const int top = vertex({center.x(), center.y(), z0 + height});
  for (int s = 0; s < segments; ++s)
    tri(ring_start[rings] + s, ring_start[rings] + (s + 1) % segments, top);
}

void MeshBuilder::staircase(const Eigen::Vector3d& origin, int steps, double rise, double tread,
                            double width, double landing) {
  // Each step is a solid block from its front edge to the back of the landing; the blocks
  // overlap, which is harmless for ray casting (only outer faces are ever hit first).
  const double run = steps * tread + landing;
  for (int k = 0; k < steps; ++k) {
    const Eigen::Vector3d lo = origin + Eigen::Vector3d(k * tread, 0.0, 0.0);
    const Eigen::Vector3d hi = origin + Eigen::Vector3d(run, width, (k + 1) * rise);
    box(lo, hi);
  }
}

void MeshBuilder::polygonDecal(const std::vector<Eigen::Vector2d>& polygon, double z) {
  if (polygon.size() < 3) return;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (const auto& p : polygon) c += p;
  c /= static_cast<double>(polygon.size());
  // Orientation: counter-clockwise polygons give +z normals with (center, p_i, p_i+1).
  double area2 = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const auto& a = polygon[i];
    const auto& b = polygon[(i + 1) % polygon.size()];
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  const int center = vertex({c.x(), c.y(), z});
  std::vector<int> ring;
  for (const auto& p : polygon) ring.push_back(vertex({p.x(), p.y(), z}));
  const std::size_t n = ring.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (area2 >= 0.0)
      tri(center, ring[i], ring[(i + 1) % n]);
    else
      tri(center, ring[(i + 1) % n], ring[i]);
  }
}

}  // namespace hazmap::sim
