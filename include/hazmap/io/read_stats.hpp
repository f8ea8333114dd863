#pragma once
#include <cstddef>
#include <string>
#include <vector>

namespace hazmap {

/// What a reader saw besides the points it returned.
struct ReadStats {
  std::size_t points_in_file = 0;      ///< records declared/present in the file
  std::size_t dropped_non_finite = 0;  ///< NaN/Inf points removed (never passed on)
  std::string format;                  ///< e.g. "kitti-bin", "pcd binary_compressed", "ply ascii"
  std::vector<std::string> fields;     ///< per-point fields in the file, in file order
};

}  // namespace hazmap
