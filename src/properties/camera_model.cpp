#include "hazmap/properties/camera_model.hpp"

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"

namespace hazmap {

std::optional<DistortionModel> parseDistortionModel(const std::string& name) {
  if (name == "none" || name.empty()) return DistortionModel::None;
  if (name == "plumb_bob" || name == "radtan" || name == "radial-tangential" || name == "radial_tangential")
    return DistortionModel::RadialTangential;
  if (name == "equidistant" || name == "fisheye") return DistortionModel::Equidistant;
  return std::nullopt;
}

const char* toString(DistortionModel model) {
  switch (model) {
    case DistortionModel::RadialTangential: return "plumb_bob";
    case DistortionModel::Equidistant: return "equidistant";
    case DistortionModel::None: break;
  }
  return "none";
}

void CameraIntrinsics::validate(const std::string& where) const {
  if (width <= 0 || height <= 0)
    fail(where, "image size " + std::to_string(width) + "x" + std::to_string(height) + " is not positive");
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0))
    fail(where, "camera_matrix: focal lengths fx, fy must be positive and finite");
  if (!(std::isfinite(cx) && std::isfinite(cy)) || cx < -0.5 || cy < -0.5 || cx > width - 0.5 ||
      cy > height - 0.5)
    fail(where, "camera_matrix: principal point (cx, cy) lies outside the image");
  for (double c : coeffs)
    if (!std::isfinite(c)) fail(where, "distortion_coefficients: a coefficient is not finite");
}

namespace {

// θ_d(θ) of the equidistant model and its derivative.
double fisheyeTheta(const std::array<double, 5>& k, double theta) {
  const double t2 = theta * theta;
  return theta * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}
double fisheyeThetaDerivative(const std::array<double, 5>& k, double theta) {
  const double t2 = theta * theta;
  return 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
}

}  // namespace

CameraModel::CameraModel(const CameraIntrinsics& intrinsics, const std::string& where) : k_(intrinsics) {
  k_.validate(where);
  max_r2_ = std::numeric_limits<double>::infinity();
  // The field the image sees: undistorted radius of the border pixels, plus a margin. Beyond it
  // a distortion polynomial may fold back and map far-off-axis points into the image.
  double r2 = 0.0;
  const double w = k_.width - 0.5, h = k_.height - 0.5;
  for (int i = 0; i <= 16; ++i) {
    const double s = i / 16.0;
    for (const Eigen::Vector2d& px : {Eigen::Vector2d(-0.5 + s * (w + 0.5), -0.5), Eigen::Vector2d(-0.5 + s * (w + 0.5), h),
                                      Eigen::Vector2d(-0.5, -0.5 + s * (h + 0.5)), Eigen::Vector2d(w, -0.5 + s * (h + 0.5))}) {
      const Eigen::Vector3d ray = unproject(px);
      if (ray.z() <= 1e-9) continue;
      r2 = std::max(r2, (ray.head<2>() / ray.z()).squaredNorm());
    }
  }
  if (k_.distortion == DistortionModel::None) return;
  max_r2_ = r2 * 1.44;  // 20 % beyond the border
  // ... but never past the radius where the radial polynomial stops growing (it folds back).
  const double r_max = std::sqrt(max_r2_);
  double last = 0.0;
  for (int i = 1; i <= 2000; ++i) {
    const double r = r_max * i / 2000.0;
    const double rd = distort(Eigen::Vector2d(r, 0.0)).x();
    if (rd <= last) {
      max_r2_ = std::pow(r_max * (i - 1) / 2000.0, 2);
      break;
    }
    last = rd;
  }
}

Eigen::Vector2d CameraModel::distort(const Eigen::Vector2d& xy) const {
  const auto& k = k_.coeffs;
  const double x = xy.x(), y = xy.y();
  switch (k_.distortion) {
    case DistortionModel::RadialTangential: {
      const double r2 = x * x + y * y;
      const double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
      return {x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x),
              y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y};
    }
    case DistortionModel::Equidistant: {
      const double r = std::sqrt(x * x + y * y);
      if (r < 1e-12) return xy;
      return xy * (fisheyeTheta(k, std::atan(r)) / r);
    }
    case DistortionModel::None: break;
  }
  return xy;
}

Eigen::Vector2d CameraModel::undistort(const Eigen::Vector2d& target) const {
  const auto& k = k_.coeffs;
  if (k_.distortion == DistortionModel::Equidistant) {
    const double theta_d = target.norm();
    if (theta_d < 1e-12) return target;
    double theta = theta_d;
    for (int it = 0; it < 30; ++it) {
      const double step = (fisheyeTheta(k, theta) - theta_d) / fisheyeThetaDerivative(k, theta);
      theta = std::clamp(theta - step, 0.0, 1.5707);
      if (std::abs(step) < 1e-14) break;
    }
    return target * (std::tan(theta) / theta_d);
  }
  if (k_.distortion != DistortionModel::RadialTangential) return target;
  // Newton with the analytic Jacobian of the plumb_bob model (OpenCV's fixed-point iteration
  // needs many more steps near the image corners).
  Eigen::Vector2d p = target;
  for (int it = 0; it < 30; ++it) {
    const double x = p.x(), y = p.y(), r2 = x * x + y * y;
    const double radial = 1 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
    const double d_radial = k[0] + r2 * (2 * k[1] + r2 * 3 * k[4]);  // d radial / d r²
    Eigen::Matrix2d J;
    J(0, 0) = radial + 2 * x * x * d_radial + 2 * k[2] * y + 6 * k[3] * x;
    J(0, 1) = 2 * x * y * d_radial + 2 * k[2] * x + 2 * k[3] * y;
    J(1, 0) = 2 * x * y * d_radial + 2 * k[2] * x + 2 * k[3] * y;
    J(1, 1) = radial + 2 * y * y * d_radial + 6 * k[2] * y + 2 * k[3] * x;
    const Eigen::Vector2d step = J.inverse() * (distort(p) - target);
    p -= step;
    if (step.squaredNorm() < 1e-28) break;
  }
  return p;
}

std::optional<Eigen::Vector2d> CameraModel::projectUnbounded(const Eigen::Vector3d& p) const {
  const Eigen::Vector2d xy = p.head<2>() / p.z();
  if (xy.squaredNorm() > max_r2_) return std::nullopt;
  const Eigen::Vector2d d = distort(xy);
  return Eigen::Vector2d(k_.fx * d.x() + k_.cx, k_.fy * d.y() + k_.cy);
}

std::optional<Eigen::Vector2d> CameraModel::project(const Eigen::Vector3d& p, double min_depth) const {
  if (!(p.z() > min_depth)) return std::nullopt;
  auto px = projectUnbounded(p);
  if (!px || !inImage(*px)) return std::nullopt;
  return px;
}

Eigen::Vector3d CameraModel::unproject(const Eigen::Vector2d& pixel) const {
  const Eigen::Vector2d d((pixel.x() - k_.cx) / k_.fx, (pixel.y() - k_.cy) / k_.fy);
  const Eigen::Vector2d xy = undistort(d);
  return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

double CameraModel::horizontalFovDeg() const {
  const Eigen::Vector3d l = unproject({-0.5, k_.cy}), r = unproject({k_.width - 0.5, k_.cy});
  return std::acos(std::clamp(l.dot(r), -1.0, 1.0)) * 180.0 / M_PI;
}

}  // namespace hazmap
