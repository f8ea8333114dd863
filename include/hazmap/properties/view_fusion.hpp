#pragma once
// Best-view fusion of the cameras across nearby scans.
//
// A camera calibration off by an angle δ moves the pixel a point reads by depth·δ/|cos θ| along
// its surface (θ the incidence angle): its "footprint". On a wall seen at a grazing angle from
// 8 m, 1° is 0.8 m, so the wall beside a hot panel reads the panel's heat; seen from 4 m the
// same spot is off by 0.2 m. So each surface voxel picks the view (scan and camera image) with
// the smallest footprint among the scans within `window` metres of travel (nearby scans, whose
// odometry has not drifted apart), as texture mapping picks the most frontal view of a face,
// and every point of the voxel is sampled in that view's image at its own position. Views are
// shared within a voxel only between points whose normals face the same way (the dominant axis
// of the world normal), so a wall does not borrow the view of the panel's side on it.
// With a camera rig (several cameras of one channel) a view is a (scan, camera) pair, so a
// point several cameras see takes the one with the smallest footprint, in its own scan or not.
//
// The same pass gives values to points the current image does not cover but a nearby scan's
// image did: the camera looks forward, and what the robot passes was in front of it a few
// metres earlier. The sample in the other image has no depth test of its own: its voxel was
// visible there (a point of it passed that scan's depth test).
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/preprocess/normals.hpp"
#include "hazmap/properties/labeler.hpp"

namespace hazmap {

struct ViewFusionConfig {
  double voxel = 0.1;    ///< m, surface cell that shares the best view (> 0)
  double window = 10.0;  ///< m of travel between the scan and the views it may take (>= 0)
  /// A view's expected misplacement of the sample on the surface, minimised over the views:
  /// footprint · calibration_uncertainty (rad, from degrees) + odometry_drift · metres travelled
  /// between the scan and the view (the poses that carry the point into the other image drift).
  double calibration_uncertainty_deg = 1.0;
  double odometry_drift = 0.05;  ///< m per m travelled
  NormalConfig normals{20, 1.0};  ///< the labeler's
  void validate(const std::string& where) const;
};

class ViewFusion {
 public:
  ViewFusion(const PropertyLabeler& labeler, ViewFusionConfig config);
  /// Records the observed points of scan `frame` (labels from PropertyLabeler::observe with
  /// footprints on), placed by T_world_scan; `travelled` = metres along the trajectory.
  /// Frames are added in increasing order.
  void add(std::size_t frame, const LabeledCloud& scan, const Eigen::Isometry3d& T_world_scan, double travelled,
           const ScanLabels& labels);
  /// After all frames were added: per point and channel (index i·channels + c) the view of
  /// the point's voxel that is best within the window, frame · cameras + camera (cameras =
  /// the labeler's camera count), -1 for none. Thread-safe.
  std::vector<std::int32_t> bestFrames(std::size_t frame, const LabeledCloud& scan) const;
  /// Replaces the channel values (and edge-guard ranges) of every point of scan `frame`
  /// (`labels` as observed for it) by samples in its best view's image; a point no view within
  /// the window saw gets NaN. Not thread-safe (it keeps a cache of decoded images).
  void fuse(std::size_t frame, const LabeledCloud& scan, const std::vector<std::int32_t>& best, ScanLabels& labels);
  std::size_t observations() const { return observations_; }

 private:
  struct View {
    float travelled, footprint;
    std::uint32_t frame;
    std::uint16_t channel;
    std::uint8_t facing;
    std::uint8_t camera;  ///< the camera of the rig that gave this view
  };
  struct Placement {
    Eigen::Isometry3d T_world_scan;
    double travelled = 0.0;
    std::vector<long> image_index;
    std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>> T_camera_scan;
  };
  bool key(const Eigen::Vector3d& world, std::uint64_t& out) const;
  const PropertyImage& image(std::size_t camera, long index);
  bool sample(std::size_t camera, const Placement& view, const Eigen::Vector3d& world, float& value, float& low,
              float& high);

  const PropertyLabeler& labeler_;
  ViewFusionConfig config_;
  std::unordered_map<std::uint64_t, std::vector<View>> views_;
  std::vector<Placement> frames_;
  std::map<std::pair<std::size_t, long>, PropertyImage> cache_;
  std::size_t observations_ = 0;
};

/// Metres travelled up to each pose of a trajectory (0 at the first).
std::vector<double> travelledDistance(const Trajectory& trajectory);

}  // namespace hazmap
