#pragma once
// Trajectory metrics that reproduce the two reference tools people compare against:
//  - evo (MichaelGrupp/evo): APE with Umeyama alignment (SE(3), Sim(3) or none) and RPE with
//    pairs chosen exactly as evo chooses them (by path length along the ESTIMATE, or by frames);
//  - the KITTI odometry devkit: segment errors over 100…800 m (t_err in %, r_err in deg/100 m).
// All errors are translation errors in metres unless the name says otherwise.
//
// Ground truth is called Q and the estimate P, as in evo's documentation. Both trajectories must
// already be associated pose by pose (same length, pose i ↔ pose i): use associateTrajectories()
// for TUM files with time stamps.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hazmap/io/trajectory.hpp"

namespace hazmap {

/// How the estimate is aligned to the ground truth before APE.
enum class Alignment {
  None,  ///< compare as is (both trajectories start from the same frame)
  SE3,   ///< rigid Umeyama alignment (rotation + translation), evo's `--align`
  Sim3,  ///< Umeyama with scale, evo's `--align --correct_scale` (monocular estimates)
};
const char* toString(Alignment alignment);
/// Parses "none", "se3", "sim3"; nullopt otherwise.
std::optional<Alignment> parseAlignment(const std::string& text);

/// Summary of an error sample, with numpy's definitions (std is the population std, median of
/// an even count is the mean of the two middle values).
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0;
};
/// Throws hazmap::Error("<where>: no errors to summarise") on an empty sample.
ErrorStats summarize(const std::vector<double>& errors, const std::string& where = "stats");

/// Similarity transform y ≈ scale · R · x + t.
struct SimilarityTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1.0;
  Eigen::Vector3d apply(const Eigen::Vector3d& x) const { return scale * (rotation * x) + translation; }
};

/// Umeyama (1991) least-squares fit of `target` ≈ s R `source` + t (s = 1 unless with_scale).
/// Throws hazmap::Error if the sizes differ, there are fewer than 3 points, or the source
/// points are degenerate (all equal).
SimilarityTransform umeyamaAlignment(const std::vector<Eigen::Vector3d>& source,
                                     const std::vector<Eigen::Vector3d>& target, bool with_scale);

/// Throws hazmap::Error("<where>: ...") when the trajectory is empty or has a non-finite pose
/// or time stamp.
void checkTrajectory(const Trajectory& trajectory, const std::string& where);

/// Pairs poses of two TUM-style trajectories by time stamp as evo does
/// (sync.associate_trajectories): for every stamp of the SHORTER trajectory, the nearest stamp
/// of the longer one, kept when |Δt| <= max_dt. Returns (gt, est) of equal length.
/// Throws hazmap::Error when no pair matches.
std::pair<Trajectory, Trajectory> associateTrajectories(const Trajectory& gt, const Trajectory& est,
                                                        double max_dt = 0.01);

// ---- APE / ATE ------------------------------------------------------------------------------
struct ApeResult {
  Alignment alignment = Alignment::SE3;
  SimilarityTransform transform;  ///< applied to the estimate (identity for Alignment::None)
  ErrorStats translation;         ///< ‖t(Q_i) − t(aligned P_i)‖, metres
  ErrorStats rotation_deg;        ///< angle of Q_i⁻¹ · aligned P_i, degrees
  std::vector<double> errors;     ///< per pose translation error
};
/// APE of `est` against `gt` (same length). Throws hazmap::Error on empty/mismatched/non-finite.
ApeResult computeApe(const Trajectory& gt, const Trajectory& est, Alignment alignment);

// ---- RPE ------------------------------------------------------------------------------------
enum class DeltaUnit { Metres, Frames };

struct RpeConfig {
  double delta = 10.0;                 ///< pair spacing: metres of path, or frames
  DeltaUnit unit = DeltaUnit::Metres;  ///< evo's --delta_unit m (default here) or f
  Alignment alignment = Alignment::None;  ///< evo's RPE default: no alignment
};

/// evo's filter_pairs_by_path (all_pairs = false): walk the poses accumulating the distance
/// between consecutive positions; each time it reaches `delta` the index is recorded and the
/// accumulator resets. Pairs are consecutive recorded indices (the first pose is NOT a start).
std::vector<std::pair<std::size_t, std::size_t>> rpePairsByPath(
    const std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>& poses,
    double delta);
/// evo's filter_pairs_by_index (all_pairs = false): (0, d), (d, 2d), …
std::vector<std::pair<std::size_t, std::size_t>> rpePairsByFrames(std::size_t count, std::size_t delta);

struct RpeResult {
  RpeConfig config;
  ErrorStats translation;   ///< ‖t((Q_i⁻¹Q_j)⁻¹ (P_i⁻¹P_j))‖, metres
  ErrorStats rotation_deg;  ///< angle of the same relative error, degrees
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<double> errors;
};
/// Pairs are chosen on the (aligned) ESTIMATE, as evo does. Throws hazmap::Error when the
/// trajectories are empty/mismatched/non-finite, delta <= 0, or no pair fits.
RpeResult computeRpe(const Trajectory& gt, const Trajectory& est, const RpeConfig& config = {});

// ---- KITTI devkit segment errors -----------------------------------------------------------
struct KittiConfig {
  std::vector<double> lengths{100, 200, 300, 400, 500, 600, 700, 800};  ///< segment lengths, m
  std::size_t step_size = 10;  ///< first frames of segments: 0, step, 2·step, … (devkit: 10)
};
struct KittiLengthError {
  double length = 0;
  std::size_t segments = 0;
  double t_err_pct = 0;           ///< mean translation error / length × 100
  double r_err_deg_per_100m = 0;  ///< mean rotation error / length, deg per 100 m
};
struct KittiResult {
  std::size_t segments = 0;  ///< 0 when the ground-truth path is shorter than every length
  double t_err_pct = 0;      ///< devkit's average over all segments of all lengths
  double r_err_deg_per_100m = 0;
  std::vector<KittiLengthError> per_length;  ///< lengths with at least one segment
};
/// As the devkit's calcSequenceErrors (distances measured along the ground truth, error
/// inv(P_i⁻¹P_j) · (Q_i⁻¹Q_j)), in double precision. No alignment (the devkit has none).
KittiResult computeKittiErrors(const Trajectory& gt, const Trajectory& est, const KittiConfig& config = {});

// ---- everything at once ---------------------------------------------------------------------
struct TrajectoryEvalConfig {
  /// evo_ape --align (Sim3 adds --correct_scale). With Sim3 the alignment's scale also applies
  /// to the estimate for RPE and the KITTI segment errors (evo_rpe --correct_scale,
  /// kitti-odom-eval --align 7dof): a monocular estimate is judged at the right scale.
  Alignment ape_alignment = Alignment::SE3;
  RpeConfig rpe;
  KittiConfig kitti;
};
struct TrajectoryEvaluation {
  std::size_t poses = 0;
  double gt_length_m = 0;   ///< path length of the ground truth
  double est_length_m = 0;  ///< path length of the estimate
  ApeResult ape;
  std::optional<RpeResult> rpe;  ///< nullopt when no RPE pair fits (trajectory too short)
  KittiResult kitti;             ///< segments == 0 when too short
};
TrajectoryEvaluation evaluateTrajectory(const Trajectory& gt, const Trajectory& est,
                                        const TrajectoryEvalConfig& config = {});

/// JSON object text: {"poses", "gt_length_m", "est_length_m", "ape": {alignment, scale, rmse,
/// mean, median, std, min, max, rot_rmse_deg}, "rpe": {delta, unit, pairs, rmse, mean, median,
/// std, min, max, rot_rmse_deg} or null, "kitti": {segments, t_err_pct, r_err_deg_per_100m,
/// per_length: [...]}}.
std::string toJson(const TrajectoryEvaluation& evaluation, int indent = 2);
/// Human-readable multi-line summary.
std::string toText(const TrajectoryEvaluation& evaluation);

/// Sum of distances between consecutive positions.
double pathLength(const Trajectory& trajectory);

}  // namespace hazmap
