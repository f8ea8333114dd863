#pragma once
// A rigid transform in a text file: 16 numbers (4×4 row-major, last row 0 0 0 1) or 12 (3×4
// [R|t]), separated by any white space — the form of `relative.txt` beside a scan pair and of
// `hazmap register`'s printed result.
#include <Eigen/Geometry>
#include <filesystem>

namespace hazmap {

/// Throws hazmap::Error naming the file for a non-number, a wrong count, a non-finite entry, a
/// last row other than 0 0 0 1 or a rotation part that is not a rotation (orthonormal to 1e-3,
/// determinant +1); the rotation is re-orthonormalised.
Eigen::Isometry3d readTransformFile(const std::filesystem::path& path);

}  // namespace hazmap
