#pragma once
// A calibration check for people: the camera image (false colour from cold blue to hot
// yellow) with the LiDAR points drawn where they project, coloured by their class (grey none,
// the class colour for hazards, black where the depth test hid them). Misaligned extrinsics
// show at once as hazard dots off the hot spots.
#include <Eigen/Geometry>
#include <filesystem>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/projection.hpp"

namespace hazmap {

struct OverlayConfig {
  double value_min = 15.0, value_max = 90.0;  ///< colour range of the image (channel units)
  int point_radius = 1;                       ///< dot size (pixels)
};

/// RGB pixels (row-major) of the overlay.
std::vector<std::uint8_t> renderOverlay(const PropertyImage& image, const CameraCalibration& camera,
                                        const LabeledCloud& scan, const Eigen::Isometry3d& T_camera_scan,
                                        const ClassTable& table, const ProjectionConfig& projection,
                                        const OverlayConfig& config = {});
/// Writes the overlay as a PNG (atomically).
void writeOverlayPng(const std::filesystem::path& path, const PropertyImage& image, const CameraCalibration& camera,
                     const LabeledCloud& scan, const Eigen::Isometry3d& T_camera_scan, const ClassTable& table,
                     const ProjectionConfig& projection, const OverlayConfig& config = {});

}  // namespace hazmap
