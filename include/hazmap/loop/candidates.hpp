#pragma once
// Loop candidates: which past keyframe might the current one be re-observing, and from what
// relative pose should verification start?
//
//  * Constellation matching (paper section V, "physical properties ... used as landmark
//    information"): the landmark sets of two keyframes are matched by class and by pairwise
//    distances — both invariant to where the drifting pose estimate puts the keyframes — and a
//    small RANSAC over landmark pairs (planar x, y, yaw) or triples (full 3-D) gives the relative
//    pose. It finds loops however large the drift is.
//  * Distance search (the conventional baseline): keyframes near the current one in the current
//    pose estimate, excluding recent ones; the initial guess is the estimate itself. It misses
//    loops once drift exceeds the search radius.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "hazmap/loop/landmarks.hpp"

namespace hazmap {

enum class ConstellationModel {
  Planar,  ///< x, y, yaw from landmark pairs, z offset from the inliers' mean (ground robot)
  Full3D,  ///< 6-DoF from landmark triples (Kabsch); needs >= 3 non-collinear landmarks
};

/// m; landmark pairs closer than this give no reliable yaw and are not used as hypotheses (issue
/// 37: a constant, not a key; also the lever of a constellation loop's rotation noise, loop_detector.cpp).
constexpr double kConstellationMinPairDistance = 1.5;

/// Constellation matching. Its internal gates and ranking (pair compatibility, hypotheses cap,
/// negative evidence, overlap) are named constants in src/loop/candidates.cpp.
struct ConstellationConfig {
  ConstellationModel model = ConstellationModel::Planar;
  /// A landmark is an inlier when, after the hypothesised transform, its centroid lies within
  /// this distance (m) of a same-class landmark of the other keyframe.
  double inlier_distance = 1.0;
  /// Minimum number of matched landmarks for a candidate. 3 makes the pose unique and a chance
  /// match among repeated classes unlikely; 2 is the planar minimum.
  std::size_t min_inliers = 2;
  /// Gate on the mean property value (e.g. temperature) when both landmarks have one (0 = off).
  double property_value_tolerance = 0.0;
  /// Flat upright landmarks (wall panels) face the sensor that saw them; matched panels must
  /// face the same way within this angle (rad) under the hypothesis (0 = off). This breaks the
  /// 180° ambiguity of a pair of same-class sources.
  double facing_tolerance = 0.8;
  std::uint64_t seed = 1;  ///< of the sample beyond the hypotheses cap
};

struct CandidateSearchConfig {
  ConstellationConfig constellation;
  /// Keyframes with index > query - min_index_gap are "recent" and never candidates (they are
  /// the odometry neighbours, not loops).
  std::size_t min_index_gap = 15;
  /// Distance search: keyframes within this radius (m) of the query in the current estimate.
  double search_radius = 3.0;
  /// At most this many candidates per query, best first.
  std::size_t max_candidates = 3;
};

enum class CandidateSource { Constellation, Distance };
const char* toString(CandidateSource source);

/// The outcome of matching two landmark constellations.
struct ConstellationMatch {
  Eigen::Isometry3d T_match_query = Eigen::Isometry3d::Identity();  ///< match ← query
  std::vector<std::pair<std::size_t, std::size_t>> inliers;  ///< (query landmark, match landmark)
  double rmse = 0.0;  ///< of the inlier centroid residuals (m)
  std::size_t misses = 0;  ///< unmatched landmarks within the other keyframe's visibility range
  double overlap = 1.0;    ///< 2·inliers / (2·inliers + misses)
  /// True when a clearly different pose explained as many landmarks (a symmetric
  /// constellation); such matches are not returned as candidates.
  bool ambiguous = false;
};

struct LoopCandidate {
  std::size_t query = 0;  ///< the current keyframe
  std::size_t match = 0;  ///< the past keyframe
  Eigen::Isometry3d initial_guess = Eigen::Isometry3d::Identity();  ///< T_match_query
  CandidateSource source = CandidateSource::Constellation;
  double score = 0.0;       ///< higher is better (constellation: inliers − miss_penalty·misses
                            ///< − rmse/inlier_distance;
                            ///< distance: −distance in m)
  std::size_t inliers = 0;  ///< matched landmarks (constellation only)
  double rmse = 0.0;        ///< landmark residual (constellation) or distance (m) (distance)
};

/// Matches the `query` landmarks against the `match` landmarks; nullopt when fewer than
/// min_inliers landmarks agree. An ambiguous match is returned with `ambiguous` set.
std::optional<ConstellationMatch> matchConstellations(const std::vector<PropertyLandmark>& query,
                                                      const std::vector<PropertyLandmark>& match,
                                                      const ConstellationConfig& config = {});

/// Constellation candidates for keyframe `query` among keyframes [0, query - min_index_gap],
/// using only the landmarks (no pose estimate). Ranked best first.
std::vector<LoopCandidate> findConstellationCandidates(
    std::size_t query, const std::vector<std::vector<PropertyLandmark>>& keyframe_landmarks,
    const CandidateSearchConfig& config = {});

/// Distance candidates for keyframe `query`: keyframes [0, query - min_index_gap] whose
/// estimated position (`poses` = world ← keyframe) lies within search_radius. Ranked nearest
/// first; initial guess = poses[match]⁻¹ · poses[query].
std::vector<LoopCandidate> findDistanceCandidates(std::size_t query, const PoseList& poses,
                                                  const CandidateSearchConfig& config = {});

void validate(const CandidateSearchConfig& config);

}  // namespace hazmap
