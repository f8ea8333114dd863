// --imu-rotation (include/hazmap/sources/imu_rotation.hpp).
#include "hazmap/sources/imu_rotation.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <string_view>
#include <vector>

#include "hazmap/core/error.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

std::vector<double> numbers(std::string text, const std::string& where) {
  std::replace(text.begin(), text.end(), ',', ' ');
  std::vector<std::string_view> tokens;
  io_detail::splitTokens(text, tokens);
  std::vector<double> out;
  for (const std::string_view token : tokens) {
    double v = 0.0;
    if (!io_detail::parseDouble(token, v)) fail(where, "'" + std::string(token) + "' is not a number");
    if (!std::isfinite(v)) fail(where, "'" + std::string(token) + "' is not finite");
    out.push_back(v);
  }
  return out;
}

Eigen::Matrix3d checkedRotation(const Eigen::Matrix3d& R, const std::string& where) {
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0.0)
    fail(where, "the matrix is not a rotation (RᵀR ≠ I or det < 0)");
  return Eigen::Quaterniond(R).normalized().toRotationMatrix();  // exactly orthonormal
}

}  // namespace

Eigen::Matrix3d parseImuRotation(const std::string& text, const std::string& where) {
  const std::vector<double> v = numbers(text, where);
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  switch (v.size()) {
    case 3:
      return (Eigen::AngleAxisd(v[2] * kDeg, Eigen::Vector3d::UnitZ()) *
              Eigen::AngleAxisd(v[1] * kDeg, Eigen::Vector3d::UnitY()) *
              Eigen::AngleAxisd(v[0] * kDeg, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
    case 4: {
      const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
      if (std::abs(q.norm() - 1.0) > 1e-3) fail(where, "the quaternion qw,qx,qy,qz is not a unit quaternion");
      return q.normalized().toRotationMatrix();
    }
    case 9:
      return checkedRotation(Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(v.data()), where);
    case 16: {
      const Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> T(v.data());
      if (T.row(3) != Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0)) fail(where, "the 4x4 matrix's last row is not 0 0 0 1");
      return checkedRotation(T.topLeftCorner<3, 3>(), where);
    }
    default:
      fail(where, "expected roll,pitch,yaw (deg), qw,qx,qy,qz, 9 (rotation) or 16 (4x4 T_lidar_imu) numbers, got " +
                      std::to_string(v.size()));
  }
}

}  // namespace hazmap
