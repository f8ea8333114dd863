#pragma once
// Simulated property cameras mounted with the LiDAR: a thermal camera (temperature, °C), a
// near-infrared camera (nir_reflectance: water absorbs NIR, so puddles look dark) and a gamma
// camera (dose_rate, µSv/h). Each renders one image per frame by ray casting the scene from
// its true pose; a pixel's value comes from the property region its surface point lies in.
// What it writes as camera.yaml can be perturbed (calibration error, time offset) to see how a
// real, imperfect calibration mislabels points — at edges, not at random.
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/property_image.hpp"

namespace hazmap::sim {

class Simulator;

struct SimCameraConfig {
  std::string name = "thermal";  ///< folder and camera name (a rig's cameras: <kind>_<placement>)
  std::string kind;              ///< thermal | nir | gamma (sets the channel); empty = the name
  int width = 640, height = 512;
  double hfov_deg = 50.0;        ///< horizontal field of view
  double k1 = -0.05, k2 = 0.01;  ///< plumb_bob radial distortion of the lens
  Eigen::Vector3d position{0.05, 0.0, 0.1};  ///< m, camera centre in the LiDAR frame
  double pitch_deg = 0.0;        ///< positive looks down; 0 = looking forward along LiDAR x
  double yaw_deg = 0.0;          ///< positive turns left (about LiDAR z); 180 = looking back
  double background = 20.0;      ///< value of surfaces outside matching regions (and of misses)
  double region_value = 80.0;    ///< value of surfaces inside regions of the camera's kind
  double noise_sigma = 0.05;     ///< per-pixel Gaussian noise (thermal: NETD 50 mK)
  bool blur = false;             ///< 3×3 binomial blur (≈ one pixel): optics + mixed pixels

  /// Defaults for "thermal", "nir" or "gamma"; throws for any other name.
  static SimCameraConfig forName(const std::string& name);
  /// thermal | nir | gamma: `kind`, else the name.
  const std::string& kindName() const { return kind.empty() ? name : kind; }
  void validate(const std::string& where) const;
  /// The channel the camera's images measure (name, units, PNG scale/offset).
  PropertyChannel channel() const;
  /// True T_camera_lidar (optical frame: x right, y down, z forward).
  Eigen::Isometry3d cameraFromLidar() const;
  CameraIntrinsics intrinsics() const;
};

/// Where one camera of a rig sits: each camera of the list is placed there too
/// (`<kind>_<name>`), turned by yaw_deg about the LiDAR's z, its mount position with it.
struct RigPlacement {
  std::string name;        ///< suffix of the cameras' names (front, left, rear, right, …)
  double yaw_deg = 0.0;    ///< positive turns left
  double hfov_deg = 0.0;   ///< 0 = the camera's own
};

struct CameraSimConfig {
  std::vector<SimCameraConfig> cameras;
  /// Camera rig: empty = each camera once, as listed; else every listed camera at every
  /// placement (ring4: four 90° cameras at 0/90/180/270°; front-rear: 0° and 180°).
  std::vector<RigPlacement> rig;
  double calibration_error_deg = 0.0;  ///< rotation error of the written T_camera_lidar
  double calibration_error_m = 0.0;    ///< translation error of the written T_camera_lidar
  double time_offset = 0.0;            ///< s, error of the written time_offset
  bool empty() const { return cameras.empty(); }
  void validate(const std::string& where) const;
  /// Parses "thermal,nir,gamma".
  static std::vector<SimCameraConfig> parseList(const std::string& list);
  /// The rig presets: "ring4", "front-rear"; throws for any other name.
  static std::vector<RigPlacement> rigPreset(const std::string& name);
  /// The cameras rendered: `cameras`, or each of them at every rig placement (at most 8).
  std::vector<SimCameraConfig> placedCameras() const;
  /// Parses "1deg,2cm" (units deg/rad and m/cm/mm) into the two calibration errors.
  void parseCalibrationError(const std::string& text);
};

/// Field tables: `cameras:` of the simulator config, e.g.
///   cameras:
///     list: [thermal, {name: nir, pitch_deg: 20, blur: true}]
///     calibration_error_deg: 1
const ConfigFields<SimCameraConfig>& configFields(ConfigTag<SimCameraConfig>);
const ConfigFields<CameraSimConfig>& configFields(ConfigTag<CameraSimConfig>);
const ConfigFields<RigPlacement>& configFields(ConfigTag<RigPlacement>);

/// The calibration camera `index` writes: true model and pose, perturbed by the configured
/// errors (random axis and direction, fixed by the seed).
CameraCalibration writtenCalibration(const SimCameraConfig& camera, const CameraSimConfig& config,
                                     std::uint64_t seed, std::size_t index);

/// Renders one camera's images (raw 16-bit counts in the channel's encoding). The pixel rays
/// are computed once; render() is thread-safe and deterministic per (seed, camera, frame).
class CameraRenderer {
 public:
  CameraRenderer(const Simulator& sim, SimCameraConfig camera, std::size_t camera_index);
  /// The image as channel values (before encoding), noise and blur included.
  std::vector<float> renderValues(std::size_t frame) const;
  Gray16 render(std::size_t frame) const;
  const SimCameraConfig& camera() const { return camera_; }

 private:
  const Simulator& sim_;
  SimCameraConfig camera_;
  std::size_t index_;
  std::vector<Eigen::Vector3f> rays_;  ///< unit pixel rays in the camera frame, row-major
  std::vector<ClassId> region_classes_;  ///< classes whose regions take region_value
};

/// Writes cameras/<name>/NNNNNN.png, times.txt and camera.yaml for every placed camera, and with
/// a rig cameras/rig.yaml listing them (`hazmap label --camera cameras/rig.yaml`).
void writeCameraImages(const Simulator& sim, const CameraSimConfig& config, const std::filesystem::path& dir);

}  // namespace hazmap::sim
