#pragma once
// Frame-to-frame tracking exactly as the paper sets it up (Fig. 1): the initial guess of each
// registration is the wheel-odometry increment (or the previous increment — constant velocity —
// without odometry); the result is checked and replaced by the odometry increment when ICP
// failed (low fitness, high RMSE, a correction far larger than odometry can be wrong by, no
// convergence). Along degenerate directions (a featureless corridor) the ICP solution is
// remapped to the guess, since the scans say nothing there (Zhang et al., ICRA 2016).
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/preprocess/crop.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

struct TrackingConfig {
  RangeCropConfig crop{0.6, 60.0};  ///< m: drop the robot body and sparse far returns
  /// Voxel size (m) of the registration clouds; property classes survive the vote when they
  /// hold at least `property_share` of a voxel (they are rare and carry the signal).
  double voxel_size = 0.2;
  double property_share = 0.25;
  /// Huber rather than a redescending kernel: a slipping crawler starts ICP 0.2–0.5 m off, and
  /// the paper's wide same-class matches then carry the largest residuals — the very ones that
  /// fix the slip; Geman–McClure silences them in the first iterations (measured on `naraha`).
  RegistrationConfig registration = [] {
    RegistrationConfig r;
    r.robust_kernel = RobustKernel::Huber;
    return r;
  }();
  // --- failure detection: fall back to the odometry increment ---
  double min_fitness = 0.3;                ///< fraction of matched source points
  double max_rmse = 0.3;                   ///< m
  double max_correction_translation = 1.0; ///< m, |ICP − guess|
  double max_correction_rotation = 0.2;    ///< rad
  /// Along directions the registration reports as degenerate, keep the guess.
  bool remap_degenerate = true;
  /// Floors on the increment's standard deviations before the covariance is inverted into an
  /// edge information (m, rad).
  double min_translation_sigma = 0.005;
  double min_rotation_sigma = 0.0005;

  /// Reads the keys above (`crop: {min_range, max_range}`, `registration:` as in
  /// registrationConfigFromYaml) on top of `base`; unknown keys are errors naming `where`.
  static TrackingConfig fromYamlString(const std::string& yaml, const std::string& where,
                                       const TrackingConfig& base);
  std::string toYamlString() const;
  void validate() const;
};

struct TrackedFrame {
  Eigen::Isometry3d T_prev_curr = Eigen::Isometry3d::Identity();
  Matrix6d covariance = Matrix6d::Identity();  ///< of T_prev_curr, translation first
  bool icp_used = false;
  std::string fallback_reason;  ///< why the guess was used (empty when ICP was used)
  double fitness = 0.0, rmse = 0.0;
  int iterations = 0;
  std::size_t points = 0;
  std::size_t degenerate_directions = 0;
  LabeledCloud preprocessed;  ///< the frame's registration cloud (sensor frame)
};

class FrameTracker {
 public:
  FrameTracker(ClassTable classes, TrackingConfig config);
  ~FrameTracker();
  /// Registers `scan` (sensor frame, raw) against the previous frame. The first frame returns
  /// identity. `odometry_increment` = T_prev_curr from the wheel encoders, if any.
  TrackedFrame track(const LabeledCloud& scan, const std::optional<Eigen::Isometry3d>& odometry_increment);
  /// Crop + class-preserving voxel downsampling used for registration.
  LabeledCloud preprocess(const LabeledCloud& scan) const;

 private:
  struct State;
  ClassTable classes_;
  TrackingConfig config_;
  std::unique_ptr<State> state_;
};

}  // namespace hazmap
