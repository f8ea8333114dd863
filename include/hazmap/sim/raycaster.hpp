#pragma once
// Ray casting against a triangle mesh with Embree 3. Building the BVH is the expensive part and
// happens once, in the constructor; casting is thread-safe (const) afterwards.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "hazmap/io/ply.hpp"

namespace hazmap::sim {

struct RayHit {
  float distance = std::numeric_limits<float>::infinity();  ///< along the unit direction (m)
  std::uint32_t triangle = 0;
  Eigen::Vector3f normal = Eigen::Vector3f::Zero();  ///< unit geometric normal of the triangle
  bool hit() const { return distance < std::numeric_limits<float>::infinity(); }
};

class RayCaster {
 public:
  /// Builds the BVH. Throws hazmap::Error for an empty mesh or an Embree failure.
  explicit RayCaster(const TriangleMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  /// Seconds spent building the BVH.
  double buildSeconds() const { return build_seconds_; }

  /// Casts rays from one origin along unit `directions`; hits closer than t_near or farther than
  /// t_far are reported as misses. `hits` is resized to directions.size().
  void cast(const Eigen::Vector3f& origin, std::span<const Eigen::Vector3f> directions,
            float t_near, float t_far, std::vector<RayHit>& hits) const;
  /// One ray (convenience for tests).
  RayHit cast(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float t_near = 0.0f,
              float t_far = std::numeric_limits<float>::infinity()) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  double build_seconds_ = 0.0;
};

}  // namespace hazmap::sim
