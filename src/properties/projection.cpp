#include "hazmap/properties/projection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"

namespace hazmap {

void ProjectionConfig::validate(const std::string& where) const {
  if (!(min_depth >= 0)) fail(where, "projection min_depth must be >= 0");
  if (depth_cell_px < 1) fail(where, "projection depth_cell_px must be >= 1");
  if (splat_cells < 0 || splat_cells > 16) fail(where, "projection splat_cells must be in [0, 16]");
  if (edge_guard_px < 0 || edge_guard_px > 64) fail(where, "projection edge_guard_px must be in [0, 64]");
  if (!(depth_tolerance >= 0) || !(depth_tolerance_ratio >= 0))
    fail(where, "projection depth tolerances must be >= 0");
}

float sampleBilinear(const PropertyImage& image, float u, float v) {
  const float x = std::clamp(u, 0.0f, static_cast<float>(image.width - 1));
  const float y = std::clamp(v, 0.0f, static_cast<float>(image.height - 1));
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const int x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
  const float ax = x - x0, ay = y - y0;
  const float top = (1 - ax) * image.at(x0, y0) + ax * image.at(x1, y0);
  const float bottom = (1 - ax) * image.at(x0, y1) + ax * image.at(x1, y1);
  return (1 - ay) * top + ay * bottom;
}

namespace {

constexpr float kFar = std::numeric_limits<float>::infinity();

/// Separable min filter of radius r over a cw × ch grid (in → out, using out as scratch too).
void minFilter(const std::vector<float>& in, std::vector<float>& tmp, std::vector<float>& out, int cw, int ch, int r) {
  tmp.resize(in.size());
  out.resize(in.size());
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x) {
      float m = kFar;
      for (int k = std::max(0, x - r); k <= std::min(cw - 1, x + r); ++k) m = std::min(m, in[y * cw + k]);
      tmp[y * cw + x] = m;
    }
  for (int y = 0; y < ch; ++y)
    for (int x = 0; x < cw; ++x) {
      float m = kFar;
      for (int k = std::max(0, y - r); k <= std::min(ch - 1, y + r); ++k) m = std::min(m, tmp[k * cw + x]);
      out[y * cw + x] = m;
    }
}

}  // namespace

void pixelRange(const PropertyImage& image, float u, float v, int r, float& lo, float& hi) {
  const int cx = static_cast<int>(std::lround(u)), cy = static_cast<int>(std::lround(v));
  lo = std::numeric_limits<float>::infinity();
  hi = -lo;
  for (int y = std::max(0, cy - r); y <= std::min(image.height - 1, cy + r); ++y)
    for (int x = std::max(0, cx - r); x <= std::min(image.width - 1, cx + r); ++x) {
      const float p = image.at(x, y);
      if (!std::isfinite(p)) continue;
      lo = std::min(lo, p);
      hi = std::max(hi, p);
    }
}

ProjectionStats projectIntoImage(std::span<const Eigen::Vector3f> points, const Eigen::Isometry3d& T,
                                 const CameraModel& camera, const PropertyImage& image,
                                 const ProjectionConfig& config, std::span<float> values,
                                 std::span<std::uint8_t> in_view, ProjectionScratch* scratch, std::span<float> low,
                                 std::span<float> high) {
  if (image.width != camera.width() || image.height != camera.height())
    fail("projection", "image size differs from the camera's calibration");
  if (values.size() != points.size() || (!in_view.empty() && in_view.size() != points.size()))
    fail("projection", "values/in_view must have one entry per point");
  ProjectionScratch local;
  ProjectionScratch& s = scratch ? *scratch : local;
  const std::size_t n = points.size();
  s.u.resize(n);
  s.v.resize(n);
  s.depth.resize(n);
  const int cell = config.depth_cell_px;
  const int cw = (camera.width() + cell - 1) / cell, ch = (camera.height() + cell - 1) / cell;
  s.zbuffer.assign(static_cast<std::size_t>(cw) * ch, kFar);
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float min_depth = static_cast<float>(config.min_depth);
  const float inv_cell = 1.0f / cell;
  ProjectionStats stats;
  // Pass 1: pixel and depth of every point; nearest depth per cell.
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f p = R * points[i] + t;
    s.depth[i] = -1.0f;  // not in view
    if (!(p.z() > min_depth)) continue;
    const auto px = camera.projectUnbounded(p.cast<double>());
    if (!px || !camera.inImage(*px)) continue;
    s.u[i] = static_cast<float>(px->x());
    s.v[i] = static_cast<float>(px->y());
    s.depth[i] = p.z();
    const int cx = static_cast<int>((s.u[i] + 0.5f) * inv_cell), cy = static_cast<int>((s.v[i] + 0.5f) * inv_cell);
    float& z = s.zbuffer[static_cast<std::size_t>(cy) * cw + cx];
    z = std::min(z, p.z());
  }
  // Pass 2: each cell's nearest depth over its neighbourhood (the splat).
  const std::vector<float>* nearest = &s.zbuffer;
  if (config.splat_cells > 0) {
    std::vector<float> tmp;
    minFilter(s.zbuffer, tmp, s.zfiltered, cw, ch, config.splat_cells);
    nearest = &s.zfiltered;
  }
  // Pass 3: depth test and bilinear sample.
  const float tol = static_cast<float>(config.depth_tolerance), ratio = static_cast<float>(config.depth_tolerance_ratio);
  for (std::size_t i = 0; i < n; ++i) {
    const float z = s.depth[i];
    if (z < 0) continue;
    ++stats.in_view;
    if (!in_view.empty()) in_view[i] = 1;
    const int cx = static_cast<int>((s.u[i] + 0.5f) * inv_cell), cy = static_cast<int>((s.v[i] + 0.5f) * inv_cell);
    const float front = (*nearest)[static_cast<std::size_t>(cy) * cw + cx];
    if (z > front + tol + ratio * front) {
      ++stats.occluded;
      continue;
    }
    const float value = sampleBilinear(image, s.u[i], s.v[i]);
    if (!std::isfinite(value)) continue;
    ++stats.observed;
    if (!std::isnan(values[i])) continue;
    values[i] = value;
    if (config.edge_guard_px > 0 && low.size() == n && high.size() == n)
      pixelRange(image, s.u[i], s.v[i], config.edge_guard_px, low[i], high[i]);
  }
  return stats;
}

}  // namespace hazmap
