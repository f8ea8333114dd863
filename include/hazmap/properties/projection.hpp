#pragma once
// Projecting a LiDAR scan into one property image: each point gets the bilinearly interpolated
// pixel value where it lands, unless a nearer surface of the same scan covers that spot in the
// image (depth test), in which case the camera saw the nearer surface, not the point.
//
// The depth test is a z-buffer of the projected scan on a grid of depth_cell_px-pixel cells,
// dilated by splat_cells (a point covers its neighbouring cells: a LiDAR scan is sparse, so a
// wall's points leave gaps between them through which the wall's background would otherwise
// "show"). A point is hidden when it lies farther than the nearest depth around it by more than
// depth_tolerance + depth_tolerance_ratio · depth.
#include <Eigen/Geometry>
#include <cstdint>
#include <span>
#include <vector>

#include "hazmap/properties/camera_model.hpp"
#include "hazmap/properties/property_image.hpp"

namespace hazmap {

struct ProjectionConfig {
  double min_depth = 0.2;               ///< m; closer points are not projected
  int depth_cell_px = 4;                ///< z-buffer cell size (pixels, >= 1)
  int splat_cells = 2;                  ///< z-buffer dilation radius (cells, >= 0)
  double depth_tolerance = 0.15;        ///< m
  double depth_tolerance_ratio = 0.05;  ///< share of the depth added to the tolerance
  /// Edge guard (0 = off): also report the smallest and largest pixel value within this many
  /// pixels of each point, so a labeler can refuse a class the calibration's error could flip.
  int edge_guard_px = 0;
  void validate(const std::string& where) const;
};

struct ProjectionStats {
  std::size_t in_view = 0;   ///< points inside the image, in front of the camera
  std::size_t occluded = 0;  ///< of those, hidden behind a nearer surface
  std::size_t observed = 0;  ///< got a value (in view, visible, finite pixels)
  ProjectionStats& operator+=(const ProjectionStats& o) {
    in_view += o.in_view;
    occluded += o.occluded;
    observed += o.observed;
    return *this;
  }
};

/// Reusable buffers (one per thread) so a scan does not allocate.
struct ProjectionScratch {
  std::vector<float> u, v, depth, zbuffer, zfiltered;
};

/// Projects `points` (any frame; T_camera_points maps them into the camera) into `image`.
/// `values[i]` receives the value of a visible point only where it is still NaN (an earlier
/// camera's value wins); `in_view` (optional, points-sized) is set to 1 for points inside the
/// image. With config.edge_guard_px > 0, `low`/`high` (points-sized) receive the pixel range
/// around each point that got a value. Deterministic, single-threaded.
ProjectionStats projectIntoImage(std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& T_camera_points,
                                 const CameraModel& camera, const PropertyImage& image,
                                 const ProjectionConfig& config, std::span<float> values,
                                 std::span<std::uint8_t> in_view = {}, ProjectionScratch* scratch = nullptr,
                                 std::span<float> low = {}, std::span<float> high = {});

/// Smallest and largest finite pixel value within r pixels of (u, v) (the edge guard's range).
void pixelRange(const PropertyImage& image, float u, float v, int r, float& low, float& high);

/// Bilinear interpolation at a pixel position (pixel centres at integers; clamped at the
/// border); NaN if any of the four pixels is NaN.
float sampleBilinear(const PropertyImage& image, float u, float v);

}  // namespace hazmap
