#pragma once
// A REIMPLEMENTATION of KISS-ICP's published method, as a baseline for benchmarks and tests only
// (never part of the library): Vizzo et al., "KISS-ICP: In Defense of Point-to-Point ICP —
// Simple, Accurate, and Robust Registration If Done the Right Way", RA-L 2023. KISS-ICP itself
// cannot be fetched or built on this machine; this follows the paper and its documented
// defaults: constant-velocity prediction, double downsampling (the scan at 0.5 × voxel enters the
// map, at 1.5 × voxel it is registered), a voxel-hash local map (20 points per voxel, voxels
// beyond max_range from the sensor dropped), an adaptive correspondence threshold σ from the
// motion model's deviation (initial 2 m, deviations below 0.1 m ignored), point-to-point ICP over
// the 27 neighbouring voxels with gate 3σ and a Geman–McClure kernel of scale σ/3. Not done:
// deskewing (the shared scans carry no per-point times, or the trackers compared get none).
#include <Eigen/Geometry>
#include <memory>
#include <vector>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap::baseline {

struct KissIcpConfig {
  double max_range = 100.0;   ///< m
  double min_range = 0.0;     ///< m
  double voxel_size = 1.0;    ///< m; KISS-ICP's default max_range / 100
  int max_points_per_voxel = 20;
  double initial_threshold = 2.0;  ///< m
  double min_motion_threshold = 0.1;  ///< m
  int max_iterations = 500;
  double convergence = 1e-4;
};

class KissIcp {
 public:
  struct Map;  ///< the voxel-hash local map
  explicit KissIcp(const KissIcpConfig& config = {});
  ~KissIcp();
  /// Registers the next scan (sensor frame) and returns its pose (world ← sensor).
  Eigen::Isometry3d addFrame(const LabeledCloud& scan);
  const std::vector<Eigen::Isometry3d>& poses() const { return poses_; }
  /// The correspondence threshold σ the last frame used (m).
  double lastSigma() const { return last_sigma_; }

 private:
  double threshold() const;
  KissIcpConfig config_;
  std::vector<Eigen::Isometry3d> poses_;
  Eigen::Isometry3d last_delta_ = Eigen::Isometry3d::Identity();
  double model_sse_ = 0.0;
  int model_samples_ = 0;
  double last_sigma_ = 0.0;
  std::unique_ptr<Map> map_;
};

}  // namespace hazmap::baseline
