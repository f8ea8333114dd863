#pragma once
// The noise of the edges tracking gives the pose graph (paper eq. 3: information = inverse ICP
// covariance): an odometry increment's covariance, floored so that an over-confident ICP cannot
// make an edge rigid, or the wheels' when the tracker fell back to the encoders; and the share
// of an increment no registration vouched for, which the map anchors carry (map_anchors.hpp).
#include "hazmap/core/se3.hpp"
#include "hazmap/odometry/odometry.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap::pipeline_detail {

/// The inverse of a covariance, its eigenvalues bounded below by 1e-12 first.
Matrix6d inverseOf(const Matrix6d& covariance);
/// The diagonal (t2, t2, t2, r2, r2, r2), translation first.
Vector6d translationRotationDiagonal(double t2, double r2);

/// An odometry edge's covariance (what the loop gate chains) and information (what the graph gets).
struct EdgeNoise {
  Matrix6d covariance, information;
};
/// The registration's floored covariance, or the wheel noise for a frame that fell back.
EdgeNoise odometryEdgeNoise(const FrameRecord& rec, const SlamConfig& config);
/// The floored registration covariance of a tracked increment (slam.min_*_sigma).
Matrix6d registrationEdgeCovariance(const FrameRecord& rec, const SlamConfig& config);
/// FrameRecord::guess_covariance of a tracked frame: all of a fallback's covariance; for a
/// degenerate frame to map, what the tracker added along the directions where it kept the guess.
Matrix6d guessCovariance(const OdometryFrame& f, OdometryMode mode);

}  // namespace hazmap::pipeline_detail
