#include "hazmap/io/transform_file.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {
namespace {

std::vector<double> readNumbers(const std::filesystem::path& path) {
  std::istringstream in(readTextFile(path));
  std::vector<double> v;
  std::string token;
  while (in >> token) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(token, &used));
      if (used != token.size()) throw std::invalid_argument(token);
    } catch (const std::exception&) {
      fail(path, "not a number: '" + token + "' (expected a 4x4 row-major matrix)");
    }
  }
  return v;
}

}  // namespace

Eigen::Isometry3d readTransformFile(const std::filesystem::path& path) {
  const std::vector<double> v = readNumbers(path);
  if (v.size() != 16 && v.size() != 12)
    fail(path, "expected 16 numbers (4x4 row-major) or 12 (3x4), found " + std::to_string(v.size()));
  for (double x : v)
    if (!std::isfinite(x)) fail(path, "the transform has a non-finite entry");
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  for (std::size_t k = 0; k < v.size(); ++k) m(k / 4, k % 4) = v[k];
  if (v.size() == 16 && (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6)
    fail(path, "the last row must be 0 0 0 1");
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    fail(path, "the rotation part is not a rotation matrix");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = projectToSO3(R);
  T.translation() = m.topRightCorner<3, 1>();
  return T;
}

}  // namespace hazmap
