#pragma once
// The properties stage: a LiDAR scan + the cameras' images → per-point channel values
// (temperature, nir_reflectance, dose_rate, …; NaN = not observed) and classes from rules.
//
// Each camera uses its image nearest in time to the scan (image stamp + time_offset, within
// time_tolerance). With a pose source the image is placed where the LiDAR was when the image
// was taken (poses interpolated), so a moving robot does not smear properties; without one the
// robot is assumed to stand still between the two instants.
#include <Eigen/Geometry>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/projection.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/properties/rules.hpp"

namespace hazmap {

class VoxelHashIndex;  // preprocess/spatial_index.hpp (normals of the footprints)

/// Where a camera's images come from (a folder, a bag topic, memory).
class ImageSource {
 public:
  virtual ~ImageSource() = default;
  /// Image stamps in the camera's clock, sorted.
  virtual const std::vector<double>& stamps() const = 0;
  /// Image i in the camera's channel units (throws hazmap::Error naming the image).
  virtual PropertyImage load(std::size_t i, const CameraCalibration& camera) const = 0;
};

/// ImageSource over an ImageFolder.
class FolderImages : public ImageSource {
 public:
  explicit FolderImages(const std::filesystem::path& dir) : folder_(dir) {}
  const std::vector<double>& stamps() const override { return folder_.stamps(); }
  PropertyImage load(std::size_t i, const CameraCalibration& camera) const override { return folder_.load(i, camera); }

 private:
  ImageFolder folder_;
};

/// ImageSource holding decoded images (e.g. from a bag topic).
class MemoryImages : public ImageSource {
 public:
  void add(PropertyImage image);  ///< stamps must not decrease
  const std::vector<double>& stamps() const override { return stamps_; }
  PropertyImage load(std::size_t i, const CameraCalibration&) const override { return images_.at(i); }

 private:
  std::vector<PropertyImage> images_;
  std::vector<double> stamps_;
};

struct CameraInput {
  CameraCalibration camera;
  std::shared_ptr<const ImageSource> images;
};

struct LabelerConfig {
  ProjectionConfig projection;
  double time_tolerance = 0.1;      ///< s, |image time − scan time| allowed
  bool motion_compensation = true;  ///< place each image with the pose at its own time
  NormalConfig normals{20, 1.0};    ///< for normal_z (only computed when a rule uses it)
  /// Also compute each observed point's calibration footprint (ScanLabels::footprint), which
  /// view fusion (view_fusion.hpp) needs to pick the best view of a surface.
  bool footprints = false;
  void validate(const std::string& where) const;
};

/// T_world_lidar at a time, or nullopt when unknown.
using PoseAtTime = std::function<std::optional<Eigen::Isometry3d>(double)>;
/// Linear interpolation of a trajectory (slerp on rotation) at t; nullopt outside its stamps.
std::optional<Eigen::Isometry3d> interpolatePose(const Trajectory& trajectory, double t);

struct ScanLabels {
  std::vector<std::vector<float>> channels;  ///< per channel (PropertyLabeler::channels()), NaN = not observed
  /// Per channel, with the edge guard on: the smallest / largest pixel value near each point.
  std::vector<std::vector<float>> low, high;
  /// Per channel, with LabelerConfig::footprints: distance from the camera / |cos(incidence)|
  /// of each observed point (m per radian of pointing error: how far along its surface an
  /// angular calibration error moves the pixel it reads); NaN where not observed.
  std::vector<std::vector<float>> footprint;
  /// With footprints: each observed point's PCA normal (LiDAR frame; zero = none).
  std::vector<Eigen::Vector3f> normals;
  /// Per channel shared by several cameras (a rig): the camera whose value each point took
  /// (the smallest footprint with footprints on, else the first camera that saw it); empty
  /// for a channel with one camera.
  std::vector<std::vector<std::uint8_t>> source_camera;
  std::vector<ClassId> classes;
  std::vector<std::uint8_t> in_view;  ///< 1 where the point lies inside some camera's image
  /// Per camera: the image used (-1 = none within the tolerance) and where it was taken.
  std::vector<long> image_index;
  std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> T_camera_scan;
  std::size_t images_used = 0;
  std::size_t images_missing = 0;     ///< cameras without an image within the tolerance
  ProjectionStats projection;
};

class PropertyLabeler {
 public:
  /// Checks that the rules only use channels the cameras give (or normal_z).
  PropertyLabeler(std::vector<CameraInput> cameras, PropertyRules rules, LabelerConfig config = {});
  /// Channel names in output order (first camera's channel first, duplicates merged).
  const std::vector<std::string>& channels() const { return channels_; }
  /// Index into channels() of camera c's channel.
  int cameraChannel(std::size_t c) const { return camera_channel_.at(c); }
  /// How many cameras give channel ch.
  std::size_t camerasOfChannel(std::size_t ch) const;
  const std::vector<CameraInput>& cameras() const { return cameras_; }
  const PropertyRules& rules() const { return rules_; }
  const LabelerConfig& config() const { return config_; }

  /// Labels one scan (LiDAR frame, taken at `time` on the LiDAR clock): observe + classify.
  /// Thread-safe.
  ScanLabels label(const LabeledCloud& scan, double time, const PoseAtTime& pose_at = {}) const;
  /// The cameras' values for one scan (channels, guard ranges, footprints), no classes yet.
  ScanLabels observe(const LabeledCloud& scan, double time, const PoseAtTime& pose_at = {}) const;
  /// Classes from the rules over labels.channels (normal_z in the world frame of T_world_scan
  /// when given, else of the scan).
  void classify(const LabeledCloud& scan, const std::optional<Eigen::Isometry3d>& T_world_scan, ScanLabels& labels) const;
  /// Writes the labels into the scan: classes, and property = the first channel.
  static void apply(const ScanLabels& labels, LabeledCloud& scan);

 private:
  std::vector<CameraInput> cameras_;
  std::vector<int> camera_channel_;  ///< per camera: index into channels_
  std::vector<std::string> channels_;
  PropertyRules rules_;
  void observeCamera(std::size_t c, const LabeledCloud& scan, const PropertyImage& image,
                     const Eigen::Isometry3d& T_camera_scan, ProjectionScratch& scratch,
                     std::unique_ptr<VoxelHashIndex>& index, ScanLabels& out) const;
  LabelerConfig config_;
};

}  // namespace hazmap
