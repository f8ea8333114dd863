#pragma once
// The calibration of the real camera + LiDAR frame in ../shared/data/cameras/pjlab-center-camera
// (README there): plumb-bob intrinsics from center_camera-intrinsic.json (for the image's own
// size: 1200 rows, not img_dist_h's 1080) and the camera ← LiDAR extrinsic.
#include <nlohmann/json.hpp>

#include "hazmap/io/atomic_file.hpp"
#include "hazmap/properties/camera_model.hpp"
#include "test_helpers.hpp"

namespace hazmap::test {

struct RealCameraCalibration {
  CameraIntrinsics intrinsics;
  Eigen::Isometry3d T_camera_lidar = Eigen::Isometry3d::Identity();
};

inline RealCameraCalibration readRealCameraCalibration(int width, int height) {
  const auto dir = sharedData("cameras/pjlab-center-camera");
  const auto intr = nlohmann::json::parse(readTextFile(dir / "center_camera-intrinsic.json"))["center_camera-intrinsic"]["param"];
  const auto K = intr["cam_K"]["data"];
  const auto dist = intr["cam_dist"]["data"][0];
  RealCameraCalibration c;
  CameraIntrinsics& k = c.intrinsics;
  k.width = width;
  k.height = height;
  k.fx = K[0][0];
  k.cx = K[0][2];
  k.fy = K[1][1];
  k.cy = K[1][2];
  k.distortion = DistortionModel::RadialTangential;
  k.coeffs = {dist[0], dist[1], dist[2], dist[3], 0.0};
  const auto ext = nlohmann::json::parse(readTextFile(dir / "top_center_lidar-to-center_camera-extrinsic.json"));
  const auto M = ext["top_center_lidar-to-center_camera-extrinsic"]["param"]["sensor_calib"]["data"];
  for (int r = 0; r < 4; ++r)
    for (int col = 0; col < 4; ++col) c.T_camera_lidar.matrix()(r, col) = M[r][col];
  return c;
}

}  // namespace hazmap::test
