#pragma once
// Small helpers that append primitives to a TriangleMesh (outward-facing triangles).
#include <Eigen/Core>
#include <vector>

#include "hazmap/io/ply.hpp"

namespace hazmap::sim {

class MeshBuilder {
 public:
  explicit MeshBuilder(TriangleMesh& mesh) : mesh_(mesh) {}

  /// Axis-aligned box, 12 triangles.
  void box(const Eigen::Vector3d& min, const Eigen::Vector3d& max);
  /// Horizontal rectangle at height z, facing up (+z).
  void floorRect(double x0, double y0, double x1, double y1, double z);
  /// Vertical cylinder standing on z0: `segments` facets around, `rings` bands up the side,
  /// closed with a top cap.
  void cylinder(const Eigen::Vector2d& center, double radius, double z0, double height,
                int segments = 48, int rings = 6);
  /// A staircase rising along +x from `origin` (its lower-left corner on the floor): `steps`
  /// steps of `rise` x `tread`, `width` along y, then a landing `landing` long at the top.
  void staircase(const Eigen::Vector3d& origin, int steps, double rise, double tread, double width,
                 double landing);
  /// A flat polygon (star-shaped around its centroid) at height z, facing up: floor decals.
  void polygonDecal(const std::vector<Eigen::Vector2d>& polygon, double z);

 private:
  int vertex(const Eigen::Vector3d& p);
  void tri(int a, int b, int c);
  void quad(int a, int b, int c, int d);  ///< a-b-c-d counter-clockwise seen from outside
  TriangleMesh& mesh_;
};

}  // namespace hazmap::sim
