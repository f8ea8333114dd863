#include "hazmap/properties/overlay.hpp"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

/// Cold → hot: dark blue, purple, orange, yellow (an "ironbow"-like ramp).
Rgb ramp(double t) {
  static const std::array<Eigen::Vector3d, 4> stops = {Eigen::Vector3d(10, 10, 60), Eigen::Vector3d(120, 30, 140),
                                                      Eigen::Vector3d(230, 110, 30), Eigen::Vector3d(255, 240, 120)};
  t = std::clamp(t, 0.0, 1.0) * 3.0;
  const int i = std::min(static_cast<int>(t), 2);
  const Eigen::Vector3d c = stops[i] + (t - i) * (stops[i + 1] - stops[i]);
  return {static_cast<std::uint8_t>(c.x()), static_cast<std::uint8_t>(c.y()), static_cast<std::uint8_t>(c.z())};
}

}  // namespace

std::vector<std::uint8_t> renderOverlay(const PropertyImage& image, const CameraCalibration& camera,
                                        const LabeledCloud& scan, const Eigen::Isometry3d& T, const ClassTable& table,
                                        const ProjectionConfig& projection, const OverlayConfig& config) {
  const int w = image.width, h = image.height;
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(w) * h * 3);
  const double span = std::max(config.value_max - config.value_min, 1e-9);
  for (std::size_t i = 0; i < image.values.size(); ++i) {
    const Rgb c = std::isfinite(image.values[i]) ? ramp((image.values[i] - config.value_min) / span) : Rgb{0, 0, 0};
    std::copy(c.begin(), c.end(), rgb.begin() + 3 * i);
  }
  // The depth test decides which points the camera saw; hidden ones are drawn black.
  std::vector<float> values(scan.size(), NAN);
  std::vector<std::uint8_t> in_view(scan.size(), 0);
  projectIntoImage(scan.points, T, camera.model, image, projection, values, in_view);
  const Eigen::Matrix3d R = T.linear();
  // Hazard points last, so they are drawn on top.
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < scan.size(); ++i) {
      if (!in_view[i]) continue;
      const bool hazard = table.isProperty(scan.classes[i]);
      if (hazard != (pass == 1)) continue;
      const auto px = camera.model.project(R * scan.points[i].cast<double>() + T.translation());
      if (!px) continue;
      const Rgb c = std::isnan(values[i]) ? Rgb{0, 0, 0} : hazard ? table.at(scan.classes[i]).color : Rgb{200, 200, 200};
      const int cx = static_cast<int>(std::lround(px->x())), cy = static_cast<int>(std::lround(px->y()));
      for (int dy = -config.point_radius; dy <= config.point_radius; ++dy)
        for (int dx = -config.point_radius; dx <= config.point_radius; ++dx) {
          const int x = cx + dx, y = cy + dy;
          if (x < 0 || y < 0 || x >= w || y >= h) continue;
          std::copy(c.begin(), c.end(), rgb.begin() + 3 * (static_cast<std::size_t>(y) * w + x));
        }
    }
  return rgb;
}

void writeOverlayPng(const std::filesystem::path& path, const PropertyImage& image, const CameraCalibration& camera,
                     const LabeledCloud& scan, const Eigen::Isometry3d& T, const ClassTable& table,
                     const ProjectionConfig& projection, const OverlayConfig& config) {
  const auto rgb = renderOverlay(image, camera, scan, T, table, projection, config);
  std::string bytes;
  const auto sink = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(sink, &bytes, image.width, image.height, 3, rgb.data(), image.width * 3))
    fail(path.string(), "cannot encode the overlay PNG");
  writeTextAtomically(path, bytes);
}

}  // namespace hazmap
