#pragma once
// A calibrated property camera: lens (camera_model.hpp), where it sits on the robot
// (T_camera_lidar), its clock (time_offset) and the physical channel its pixels measure.
//
// camera.yaml is a ROS camera_info calibration file (what `camera_calibration` writes) plus:
//   T_camera_lidar: {rows: 4, cols: 4, data: [16 numbers, row-major]}  (or 16 numbers / 4 rows)
//   time_offset: 0.0          # s; image stamp + time_offset = the LiDAR clock's time
//   channel: {name: temperature, units: degC, scale: 0.01, offset: -273.15}
//   images: .                 # optional: folder of NNNNNN.png + times.txt (relative to the YAML)
//   topic: /thermal/image_raw # optional: the bag topic of the images
// Pixel → value: integer images (mono8, mono16, 16-bit PNG) give raw·scale + offset (the
// defaults for a `temperature` channel read centikelvin as °C); float images (32FC1) give
// raw + float_offset (0 for °C, -273.15 for K).
#include <Eigen/Geometry>
#include <filesystem>
#include <string>

#include "hazmap/properties/camera_model.hpp"

namespace hazmap {

struct PropertyChannel {
  std::string name = "temperature";  ///< the name rules refer to (temperature, nir_reflectance, dose_rate, …)
  std::string units = "degC";
  double scale = 0.01;               ///< integer pixels: value = raw · scale + offset
  double offset = -273.15;
  double float_offset = 0.0;         ///< float pixels: value = raw + float_offset
};

struct CameraCalibration {
  std::string name = "camera";
  CameraModel model;
  Eigen::Isometry3d T_camera_lidar = Eigen::Isometry3d::Identity();
  double time_offset = 0.0;  ///< s
  PropertyChannel channel;
  std::filesystem::path images;  ///< image folder (absolute, or empty)
  std::string topic;             ///< bag topic (or empty)
  std::filesystem::path source;  ///< the YAML it came from (for messages)
};

/// Reads camera.yaml. Errors name the file and the key: a missing key, a negative focal length,
/// a T_camera_lidar that is not a rigid transform (rotation block orthonormal with det +1,
/// last row 0 0 0 1), an unknown distortion model or a wrong number of coefficients.
CameraCalibration readCameraYaml(const std::filesystem::path& path);
/// `where` names the text in errors; `base_dir` resolves a relative `images:` folder.
CameraCalibration parseCameraYaml(const std::string& yaml, const std::string& where,
                                  const std::filesystem::path& base_dir = {});
/// camera.yaml text for a calibration (numbers written so they read back exactly; `images:` is
/// written as given by `images_field`, empty = left out).
std::string cameraYaml(const CameraCalibration& camera, const std::string& images_field = ".");

/// The channel defaults for a well-known channel name (temperature: centikelvin → °C;
/// nir_reflectance: 1/65535 per count; dose_rate: 0.01 µSv/h per count; others 1:1).
PropertyChannel defaultChannel(const std::string& name);

}  // namespace hazmap
