#pragma once
// The pinhole camera with lens distortion, as ROS camera_info and OpenCV define it:
//   plumb_bob / radial-tangential  D = [k1 k2 p1 p2 k3]  (OpenCV's 5-coefficient model)
//   equidistant / fisheye          D = [k1 k2 k3 k4]     (OpenCV's cv::fisheye model)
// Camera frame: x right, y down, z forward (optical). Pixel centres sit at integer coordinates
// (u = fx·x' + cx), so pixel (0, 0) covers [-0.5, 0.5]².
#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

namespace hazmap {

enum class DistortionModel { None, RadialTangential, Equidistant };

/// "none", "plumb_bob"/"radtan"/"radial-tangential", "equidistant"/"fisheye"; nullopt otherwise.
std::optional<DistortionModel> parseDistortionModel(const std::string& name);
/// The ROS name: "none", "plumb_bob", "equidistant".
const char* toString(DistortionModel model);

struct CameraIntrinsics {
  int width = 0, height = 0;  ///< pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;
  DistortionModel distortion = DistortionModel::None;
  /// plumb_bob: k1 k2 p1 p2 k3; equidistant: k1 k2 k3 k4 (the fifth stays 0).
  std::array<double, 5> coeffs{};

  /// Throws hazmap::Error("<where>: ...") for a non-positive size or focal length, a principal
  /// point outside the image, or a non-finite coefficient.
  void validate(const std::string& where) const;
};

class CameraModel {
 public:
  CameraModel() = default;
  /// Validates (see CameraIntrinsics::validate) and precomputes the field-of-view limit.
  CameraModel(const CameraIntrinsics& intrinsics, const std::string& where = "camera");

  const CameraIntrinsics& intrinsics() const { return k_; }
  int width() const { return k_.width; }
  int height() const { return k_.height; }

  /// Undistorted normalised coordinates (x/z, y/z) → distorted normalised coordinates.
  Eigen::Vector2d distort(const Eigen::Vector2d& xy) const;
  /// Inverse of distort() by Newton's method (converges in a few steps inside the image).
  Eigen::Vector2d undistort(const Eigen::Vector2d& xy_distorted) const;

  /// Pixel of a camera-frame point; nullopt behind the camera (z <= min_depth), beyond the
  /// lens model's valid field (where a polynomial folds back) or outside the image
  /// [-0.5, size - 0.5).
  std::optional<Eigen::Vector2d> project(const Eigen::Vector3d& p_camera, double min_depth = 1e-6) const;
  /// Pixel of a direction with z > 0 without the image-bounds check (may lie outside the image);
  /// nullopt only outside the lens model's valid field.
  std::optional<Eigen::Vector2d> projectUnbounded(const Eigen::Vector3d& p_camera) const;
  /// Unit ray (camera frame) through a pixel.
  Eigen::Vector3d unproject(const Eigen::Vector2d& pixel) const;

  bool inImage(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < k_.width - 0.5 &&
           pixel.y() < k_.height - 0.5;
  }
  /// Largest undistorted normalised radius² the image sees (with a margin): beyond it the
  /// distortion polynomial is not trusted.
  double maxRadiusSquared() const { return max_r2_; }
  /// Horizontal field of view through the principal point (degrees).
  double horizontalFovDeg() const;

 private:
  CameraIntrinsics k_;
  double max_r2_ = 0.0;
};

}  // namespace hazmap
