#pragma once
// LiDAR odometry on top of property-aware ICP.
//  - FrameToFrame: the paper's set-up — each scan is registered to the previous one, the initial
//    guess being the wheel-odometry increment.
//  - FrameToMap: each scan is registered to a bounded local voxel map that keeps classes.
// Without wheel odometry the guess is the last estimated increment (constant velocity). A frame
// whose registration fails (too few correspondences, low fitness, a correction far from the
// guess) falls back to the guessed increment, recording why; along degenerate directions the
// guess is kept while the constrained directions come from ICP.
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/odometry/local_map.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

enum class OdometryMode { FrameToFrame, FrameToMap };
const char* toString(OdometryMode mode);

struct OdometryConfig {
  OdometryMode mode = OdometryMode::FrameToMap;
  /// ICP settings (use_classes = property ICP or plain ICP). Odometry's defaults differ from
  /// registerClouds' in max_correspondence_distance only (see defaults()).
  RegistrationConfig registration;
  // --- preprocessing ---
  double min_range = 1.0;      ///< m; drops the robot's own body
  double max_range = 100.0;    ///< m
  double voxel_size = 0.5;     ///< m; the scan as it enters the map / the next frame's target
  double source_voxel_size = 0.0;  ///< m; the scan registered (0 = voxel_size); coarser = faster
  // --- local map (FrameToMap) ---
  LocalMapConfig map;
  // --- failure detection ---
  double min_fitness = 0.3;               ///< fraction of source points with a correspondence
  double max_correction_translation = 1.0;  ///< m; farther from the guess = diverged
  double max_correction_rotation = 0.2;     ///< rad
  bool keep_guess_along_degenerate = true;  ///< replace ICP's degenerate directions by the guess
  /// Covariance given to a fallback increment (and along degenerate directions).
  double fallback_sigma_translation = 0.1;  ///< m
  double fallback_sigma_rotation = 0.02;    ///< rad

  /// Sensible defaults for a 10 Hz spinning LiDAR (max correspondence 1.5 m, map voxel 1 m).
  static OdometryConfig defaults();
  void validate() const;
};

/// Field tables (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<OdometryConfig>& configFields(ConfigTag<OdometryConfig>);
const ConfigFields<LocalMapConfig>& configFields(ConfigTag<LocalMapConfig>);

/// YAML: the keys of the field table, at top level or under `odometry:`; `map:` and
/// `registration:` are nested sections. Unknown keys are errors naming the closest valid key.
OdometryConfig odometryConfigFromYaml(const std::string& yaml, const std::string& where,
                                      const OdometryConfig& base = OdometryConfig::defaults());
OdometryConfig loadOdometryConfig(const std::string& path,
                                  const OdometryConfig& base = OdometryConfig::defaults());

enum class FrameStatus {
  First,       ///< the first frame (pose = initial pose)
  Registered,  ///< ICP result used
  Degenerate,  ///< ICP used except along degenerate directions (guess kept there)
  Fallback,    ///< ICP failed; the guessed increment was used
};
const char* toString(FrameStatus status);

struct OdometryFrame {
  std::size_t index = 0;
  double stamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();       ///< world ← sensor
  Eigen::Isometry3d increment = Eigen::Isometry3d::Identity();  ///< previous ← current
  Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();      ///< guessed increment
  /// Covariance of `increment` (left perturbation, translation first, previous frame).
  Matrix6d covariance = Matrix6d::Zero();
  FrameStatus status = FrameStatus::First;
  std::string reason;  ///< why the frame fell back / was degenerate
  bool wheel_guess = false;  ///< the guess came from wheel odometry (else constant velocity)
  RegistrationResult registration;
  std::size_t scan_points = 0, source_points = 0, map_points = 0;
  /// Wall times: preprocess = the scan's crop and downsampling (frame to map it runs beside the
  /// local map's target build); registration = the rest of the frame (target, ICP, checks, map
  /// update) = total − preprocess.
  double preprocess_ms = 0.0, registration_ms = 0.0, total_ms = 0.0;
};

class Odometry {
 public:
  Odometry(const ClassTable& classes, const OdometryConfig& config = OdometryConfig::defaults(),
           const Eigen::Isometry3d& initial_pose = Eigen::Isometry3d::Identity());
  ~Odometry();

  /// Processes the next scan (sensor frame). `wheel_increment` = previous ← current from wheel
  /// odometry, if available. Throws hazmap::Error for a class missing from the table (when
  /// classes are used) or a non-finite wheel increment; an empty scan falls back.
  const OdometryFrame& addFrame(const LabeledCloud& scan,
                                const std::optional<Eigen::Isometry3d>& wheel_increment = std::nullopt,
                                double stamp = -1.0);

  const std::vector<OdometryFrame>& frames() const { return frames_; }
  Trajectory trajectory() const;
  const LocalMap& localMap() const { return map_; }
  const OdometryConfig& config() const { return config_; }

 private:
  struct Impl;
  ClassTable classes_;
  OdometryConfig config_;
  Eigen::Isometry3d initial_pose_;
  LocalMap map_;
  std::vector<OdometryFrame> frames_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace hazmap
