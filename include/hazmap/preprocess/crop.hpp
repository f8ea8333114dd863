#pragma once
// Cropping: by range from the sensor (drops the robot's own body and far, sparse returns) and by
// an axis-aligned box. All channels and classes are kept, point order is preserved.
#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap {

struct RangeCropConfig {
  double min_range = 0.0;    ///< m, points closer than this are dropped (>= 0)
  double max_range = 100.0;  ///< m, points farther than this are dropped (> min_range)
};

/// Keeps points with min_range <= |p| <= max_range (non-finite points dropped). Throws
/// hazmap::Error on an invalid config.
LabeledCloud cropRange(const LabeledCloud& cloud, const RangeCropConfig& config);

/// Keeps the points inside `box` (or outside it when keep_inside = false).
LabeledCloud cropBox(const LabeledCloud& cloud, const AxisAlignedBox& box, bool keep_inside = true);

}  // namespace hazmap
