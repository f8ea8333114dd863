#include "hazmap/preprocess/crop.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"

namespace hazmap {

LabeledCloud cropRange(const LabeledCloud& cloud, const RangeCropConfig& config) {
  if (!(config.min_range >= 0.0) || !std::isfinite(config.min_range))
    fail("range crop", "min_range must be >= 0 (got " + std::to_string(config.min_range) + ")");
  if (!(config.max_range > config.min_range))
    fail("range crop", "max_range must be > min_range (got " + std::to_string(config.max_range) + ")");
  const double lo2 = config.min_range * config.min_range, hi2 = config.max_range * config.max_range;
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const double r2 = cloud.points[i].cast<double>().squaredNorm();
    if (std::isfinite(r2) && r2 >= lo2 && r2 <= hi2) keep.push_back(i);
  }
  return cloud.select(keep);
}

LabeledCloud cropBox(const LabeledCloud& cloud, const AxisAlignedBox& box, bool keep_inside) {
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (!p.allFinite()) continue;
    const bool inside = (p.array() >= box.min.array()).all() && (p.array() <= box.max.array()).all();
    if (inside == keep_inside) keep.push_back(i);
  }
  return cloud.select(keep);
}

}  // namespace hazmap
