#pragma once
// Global registration: aligns a scan to a target (the local map, a keyframe, the previous scan)
// WITHOUT an initial guess, for the frames where the odometry's guess is wrong (a crawler that
// slips or spins, a kidnapped robot). Steps (docs/registration.md, "Global registration"):
//  1. voxel-downsample, estimate normals, FPFH descriptors (Rusu et al., ICRA 2009: histograms
//     of the Darboux-frame angles between a point's normal and its neighbours', weighted sums of
//     the neighbours' simple histograms);
//  2. correspondences = (mutual) nearest neighbours in descriptor space; property-aware: a
//     labelled point is matched only to target points of its own class;
//  3. hypotheses: RANSAC over triples of correspondences with an edge-length pre-check, plus
//     (property-aware) the property-landmark constellations — triples of same-class clusters
//     (heat sources, puddles) whose pairwise distances agree;
//  4. every distinct hypothesis is scored by the overlap it gives (labelled points count more
//     when they land on their own class), the best ones refined by property ICP; a second
//     distinct hypothesis scoring nearly as well makes the result `ambiguous` (not accepted).
// The target's half of steps 1–2 is precomputed once (GlobalRegistrationTarget) and reused.
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

/// What the global registration's refinement ICP changes from the tracking ICP
/// (odometry.registration), and only that (issue 37: overrides, not a copy).
struct RefinementIcpOverrides {
  int max_iterations = 30;
  /// Plenty to tell a right hypothesis from a wrong one, and to refine it.
  std::size_t max_source_points = 1500;
  std::size_t coarse_source_points = 0;  ///< the downsampled scan is small already
  /// `tracking` with these fields replaced.
  RegistrationConfig over(RegistrationConfig tracking) const;
};

struct GlobalRegistrationConfig {
  // Internal thresholds (descriptor matching, hypothesis scoring, ambiguity) are named constants
  // in src/registration/global_*.cpp (issue 37).
  // --- features ---
  double voxel_size = 0.5;        ///< m, both clouds are downsampled to this first
  double normal_radius = 1.0;     ///< m, neighbourhood of the normals
  int normal_neighbors = 20;      ///< k of the normals (>= 3)
  double feature_radius = 2.5;    ///< m, FPFH neighbourhood (≈ 5 voxels)
  double max_range = 0.0;         ///< m from the cloud's origin; farther points ignored (0 = all)
  // --- estimator ---
  int ransac_iterations = 5000;       ///< triples drawn (fixed count: deterministic)
  double inlier_distance = 0.75;      ///< m, a correspondence/point agrees within this
  std::uint64_t seed = 1;             ///< RANSAC seed (the result does not depend on threads)
  /// Property-aware: labelled points match their own class, property-landmark constellations add
  /// hypotheses, and labelled points landing on their own class score more.
  bool use_classes = true;
  // --- verification ---
  double min_overlap = 0.3;        ///< refined overlap (share of source points with a partner)
  /// The property ICP of the candidates: tracking's with these overrides (its use_classes
  /// follows use_classes above).
  RefinementIcpOverrides refinement;
  /// Not a key: the tracking ICP the refinement's overrides apply to. The odometry sets it to
  /// odometry.registration (globalConfigOf); standalone (`hazmap register --global`) it keeps the
  /// default, which is tracking's default.
  RegistrationConfig tracking_registration;
  /// The winner is polished by the same ICP on clouds downsampled to this (m; finer than
  /// voxel_size: at 0.5 m a sparse scan has shallow local minima a few degrees wide). 0 = off.
  double final_voxel_size = 0.25;
  int threads = 0;  ///< 0 = TBB's default (or the surrounding tbb::global_control)

  /// The refinement ICP: tracking_registration with the refinement's overrides.
  RegistrationConfig refinementIcp() const { return refinement.over(tracking_registration); }
  /// Throws hazmap::Error naming the offending parameter ("global_registration.<key>: ...").
  void validate() const;
};

/// The field table (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<GlobalRegistrationConfig>& configFields(ConfigTag<GlobalRegistrationConfig>);
const ConfigFields<RefinementIcpOverrides>& configFields(ConfigTag<RefinementIcpOverrides>);
/// YAML at top level or under `global_registration:`; unknown keys are errors.
GlobalRegistrationConfig globalRegistrationConfigFromYaml(const std::string& yaml, const std::string& where,
                                                          const GlobalRegistrationConfig& base = {});
GlobalRegistrationConfig loadGlobalRegistrationConfig(const std::string& path,
                                                      const GlobalRegistrationConfig& base = {});

/// Why a global registration was not accepted.
enum class GlobalStatus {
  Success,
  TooFewPoints,           ///< source or target below min_points after downsampling
  TooFewFeatures,         ///< fewer than min_features points with a descriptor
  TooFewCorrespondences,  ///< fewer than 3 descriptor matches
  NoConsensus,            ///< no hypothesis passed the checks
  PoorOverlap,            ///< the best refined hypothesis overlaps less than min_overlap
  Ambiguous,              ///< two distinct hypotheses of similar score
  Degenerate,             ///< the refinement leaves directions unconstrained (reject_degenerate)
  LabelsDisagree,         ///< property-aware: the winner puts the labelled points off their class
};
const char* toString(GlobalStatus status);

struct GlobalRegistrationTimings {
  double prepare_ms = 0.0;     ///< downsampling, normals, descriptors of the source
  double match_ms = 0.0;       ///< descriptor matching
  double hypotheses_ms = 0.0;  ///< RANSAC + constellations + scoring
  double refine_ms = 0.0;      ///< property ICP of the candidates
  double total_ms = 0.0;
};

struct GlobalRegistrationResult {
  bool success = false;
  GlobalStatus status = GlobalStatus::NoConsensus;
  std::string reason;  ///< for people; empty on success
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  ///< target ← source (best, refined)
  double score = 0.0;              ///< best hypothesis (see label_score_share; = overlap when plain)
  double second_best_score = 0.0;  ///< best distinct competitor (0 = none)
  bool ambiguous = false;
  double overlap = 0.0;            ///< share of source points with a target point within inlier_distance
  std::size_t inliers = 0;         ///< descriptor correspondences agreeing with the transform
  std::size_t correspondences = 0;
  std::size_t source_points = 0;   ///< after downsampling
  std::size_t source_features = 0;
  double label_agreement = 0.0;    ///< share of labelled source points on their class (property-aware)
  std::size_t constellation_hypotheses = 0;  ///< hypotheses from landmark constellations
  bool from_constellation = false;  ///< the winning hypothesis came from landmarks, not FPFH
  RegistrationResult refinement;    ///< the property ICP that refined the winner
  GlobalRegistrationTimings timings;
};

/// A target prepared once: downsampled cloud, normals, descriptors, indexes, landmarks and the
/// ICP target used for refinement. Movable, immutable, safe to share between threads.
class GlobalRegistrationTarget {
 public:
  GlobalRegistrationTarget();
  ~GlobalRegistrationTarget();
  GlobalRegistrationTarget(GlobalRegistrationTarget&&) noexcept;
  GlobalRegistrationTarget& operator=(GlobalRegistrationTarget&&) noexcept;
  std::size_t size() const;        ///< downsampled points
  std::size_t features() const;    ///< points with a descriptor
  std::size_t landmarks() const;   ///< property landmarks (use_classes)
  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  friend GlobalRegistrationTarget prepareGlobalTarget(const LabeledCloud&, const ClassTable&,
                                                      const GlobalRegistrationConfig&,
                                                      const Eigen::Vector3f&);
  std::unique_ptr<Impl> impl_;
};

/// Prepares `target` (its own frame). `viewpoint` orients the normals (a scan: its origin; a
/// local map: the sensor position it was last seen from). Throws hazmap::Error on a bad config
/// or (use_classes) a class missing from `classes`. Too few points are not an error here: the
/// registrations against such a target fail with TooFewPoints.
GlobalRegistrationTarget prepareGlobalTarget(const LabeledCloud& target, const ClassTable& classes,
                                             const GlobalRegistrationConfig& config = {},
                                             const Eigen::Vector3f& viewpoint = Eigen::Vector3f::Zero());

/// Aligns `source` (its own frame, normals oriented towards its origin) to a prepared target.
/// `config` must be the one the target was prepared with (checked). Never throws for data
/// problems: they come back as status + reason.
GlobalRegistrationResult registerGlobally(const LabeledCloud& source, const GlobalRegistrationTarget& target,
                                          const ClassTable& classes, const GlobalRegistrationConfig& config = {});

/// One-shot convenience: prepares `target` (viewpoint = origin) and registers `source`.
GlobalRegistrationResult registerGlobally(const LabeledCloud& source, const LabeledCloud& target,
                                          const ClassTable& classes, const GlobalRegistrationConfig& config = {});

}  // namespace hazmap
