#pragma once
// Loop closure from property landmarks (paper section V), end to end:
//   keyframe → landmarks → candidates (constellation and/or distance) → property-ICP
//   verification → drift gate → pairwise-consistent set → loop edges for the pose graph.
// See docs/loop_closure.md.
#include <deque>
#include <filesystem>
#include <string>
#include <functional>
#include <memory>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/config_fwd.hpp"
#include "hazmap/loop/candidates.hpp"
#include "hazmap/loop/consistency.hpp"
#include "hazmap/loop/landmarks.hpp"
#include "hazmap/loop/verification.hpp"

namespace hazmap {

enum class CandidateMethod {
  Constellation,  ///< property-landmark constellations (hazmap's method)
  Distance,       ///< nearby in the current estimate (the conventional baseline)
  Both,
};
const char* toString(CandidateMethod method);

/// Every setting of the loop-closure stage. YAML (all keys optional, defaults below):
///   loop_closure:
///     method: constellation          # constellation | distance | both
///     max_loops_per_keyframe: 1
///     keyframe_voxel: 0.15
///     resident_keyframes: 64
///     landmark_window: 5
///     landmark_merge_distance: 1.0
///     partial_landmark_window: 10
///     partial_nearest_keyframe: true
///     partial_distance_below_landmarks: 3
///     submap_keyframes: 3
///     cross_check_query_keyframes: 6
///     landmarks:    {cluster_tolerance: 0.7, min_points: 8, max_range: 15, min_purity: 0.2}
///     candidates:   {min_index_gap: 15, search_radius: 3, max_candidates: 3,
///                    constellation: {model: planar, inlier_distance: 1, min_inliers: 2,
///                                    property_value_tolerance: 0, facing_tolerance: 0.8, seed: 1}}
///     verification: {min_fitness: 0.8, max_rmse: 0.4, reject_degenerate: true,
///                    max_correction_translation: 2, max_correction_rotation: 0.35, ...,
///                    registration: {max_correspondence_distance: 1.5, max_iterations: 60,
///                                   max_source_points: 6000, index: kdtree,
///                                   coarse_source_points: 0}}  # overrides of tracking's ICP
///                                   # (odometry.registration); the rest is tracking's
///     consistency:  {translation_drift_per_metre: 0.04, rotation_drift_per_metre: 0.004,
///                    gate_probability: 0.999}
/// Internal thresholds are named constants in the files that use them (docs/configuration.md).
struct LoopClosureConfig {
  CandidateMethod method = CandidateMethod::Constellation;
  /// Verified loops kept per query keyframe (best candidates first).
  std::size_t max_loops_per_keyframe = 1;
  /// Keyframe clouds are stored voxel-downsampled to this size (m) for verification (property
  /// points win their voxel, see preprocess/voxel_downsample.hpp); 0 = keep every point.
  /// Landmarks are always extracted from the full cloud.
  double keyframe_voxel = 0.15;
  /// With a cloud loader (LoopDetector::setCloudLoader), at most this many of the newest keyframe
  /// clouds stay in memory; older ones are reloaded when a loop candidate needs them, so a long
  /// run's memory does not grow with its keyframes' points (landmarks are always kept). >= 1.
  std::size_t resident_keyframes = 64;
  /// Constellations are built from the landmarks of this many keyframes (the keyframe and the
  /// ones before it, merged into its frame with the pose estimate; same-class landmarks within
  /// landmark_merge_distance fuse). 1 = the keyframe's own landmarks only. A VLP-16 sees a floor
  /// puddle only from 2–10 m, so one scan often holds too few landmarks for a distinctive
  /// constellation; a short window of locally accurate odometry gathers them.
  std::size_t landmark_window = 5;
  double landmark_merge_distance = 1.0;  ///< m
  /// Classes whose labels do not mark their whole extent (ClassInfo::whole_extent false: labels
  /// from a forward-looking camera) build their landmarks from this many keyframes on *each* side
  /// of the keyframe instead (0 = as the other classes). A 50° camera labels a source only while
  /// it lies ahead: the scans that pass it, or see it behind, carry no label, and a keyframe's own
  /// scan holds a fraction of the sources ground truth would give it (naraha seed 1: 0.47 vs
  /// 1.44 landmarks per keyframe). Its neighbours' views, fore and aft, restore them; the
  /// keyframes ahead are known once the robot has driven on, so each keyframe is queried again
  /// this many keyframes later (LoopDetector::detect). No effect on a table without such classes.
  std::size_t partial_landmark_window = 10;
  /// Such a neighbourhood constellation names any keyframe of the matched stretch, often one 9–13 m
  /// from the query. true: each candidate is verified at the stretch's keyframe nearest the query
  /// under the candidate's guess (the next-nearest for the query's next candidate, and so on);
  /// false: at the keyframe the constellation named. Registered from 9–13 m the loops come out
  /// biased (naraha camera labels, frame to local map: 2.5–6 cm too high, PGO worse than
  /// tracking); docs/properties.md. No effect on a table without partial classes.
  bool partial_nearest_keyframe = true;
  /// With partial classes (camera labels): a query keyframe whose constellation (its
  /// neighbourhood's landmarks, placeLandmarks) holds fewer than this many landmarks also takes
  /// distance candidates from the estimate (candidates.search_radius, as icp+pgo's), verified
  /// by the same property ICP. A forward camera leaves many keyframes with no landmark at all,
  /// where labels cannot propose a loop. 0 = off. No effect on a table without partial classes.
  /// 3 by default: on simulated naraha seeds 1–8 it lowered the camera rows' PGO map error on
  /// 6 and 8 of 8 seeds (frame to map / paper set-up) and cost 0.4 mm on two (docs/properties.md).
  std::size_t partial_distance_below_landmarks = 3;
  /// Verification target: the matched keyframe's scan together with this many keyframes on each
  /// side of it, placed with the current estimate in its frame and downsampled to keyframe_voxel
  /// (a dense *submap*, as dense as the map the tracker registers to). 0 = the matched scan alone.
  /// Only keyframes at least candidates.min_index_gap older than the query join.
  std::size_t submap_keyframes = 3;
  /// The reverse cross-check (verification.cross_check_chi2) registers the match keyframe's
  /// submap onto the query keyframe together with this many keyframes before it, placed with the
  /// current estimate in the query's frame: submap against submap, from scans the forward loop
  /// did not use on the query side. 0 = the match keyframe's scan onto the query's scan alone.
  std::size_t cross_check_query_keyframes = 6;
  /// Online cost (issue 14): a cached verification target (LoopDetector::submapTarget) is reused
  /// while every keyframe of its submap sits within this of where the target placed it (m: the
  /// placement's translation change plus its rotation change times 10 m, the submap's reach);
  /// beyond it, an optimisation moved the submap and the target is rebuilt. 0 = reused only when
  /// placed bit for bit identically (every optimisation rebuilds the targets). 5 mm (half the
  /// loop's σ floor): naraha 1 loop stage ≈ −20 % CPU, every accuracy rule kept on naraha,
  /// corridor and tanks (docs/pose_graph.md, "Online cost, second pass").
  double submap_reuse_tolerance = 0.005;
  /// Online cost (issue 14): light verification of near-duplicate candidates. A candidate whose
  /// match and query both lie within this many keyframes of a loop accepted with the full checks
  /// is verified by the same ICP, acceptance rules and basin probes, but when its answer agrees
  /// with that loop composed with the estimate's short paths at both ends (χ²₆ at
  /// consistency.gate_probability, against both loops' covariances and the graph's covariance of
  /// the two short paths) the reverse cross-check is not run again: the loop takes over that
  /// loop's verdict (the misfit term dropped or kept). A candidate that disagrees is cross-checked
  /// itself. Light loops never serve as the reference. The probes are not skipped: some
  /// near-duplicates of a sound loop are ambiguous themselves (docs/pose_graph.md, third pass). 0 = off.
  /// Default 2 since 2026-12-02: every accuracy rule held on naraha, corridor and tanks (seeds 1–8)
  /// and in the paper's set-up; naraha 1 skips 12 of 24 cross-checks.
  std::size_t light_duplicate_keyframes = 2;
  LandmarkConfig landmarks;
  CandidateSearchConfig candidates;
  VerificationConfig verification;
  ConsistencyConfig consistency;

  /// Reads a YAML file holding a `loop_closure:` mapping (or that mapping at top level).
  /// Unknown keys and bad values throw hazmap::Error naming the file and the key.
  static LoopClosureConfig fromYamlFile(const std::filesystem::path& path);
  static LoopClosureConfig fromYamlString(const std::string& yaml, const std::string& where);
  /// The full config as YAML (a `loop_closure:` mapping); fromYamlString reads it back.
  std::string toYamlString() const;
  /// Throws hazmap::Error naming the first invalid parameter.
  void validate() const;
};

/// Field tables (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<LandmarkConfig>& configFields(ConfigTag<LandmarkConfig>);
const ConfigFields<ConstellationConfig>& configFields(ConfigTag<ConstellationConfig>);
const ConfigFields<CandidateSearchConfig>& configFields(ConfigTag<CandidateSearchConfig>);
const ConfigFields<VerificationIcpOverrides>& configFields(ConfigTag<VerificationIcpOverrides>);
const ConfigFields<VerificationConfig>& configFields(ConfigTag<VerificationConfig>);
const ConfigFields<ConsistencyConfig>& configFields(ConfigTag<ConsistencyConfig>);
const ConfigFields<LoopClosureConfig>& configFields(ConfigTag<LoopClosureConfig>);

/// What happened to one query keyframe.
struct LoopDetection {
  std::vector<LoopCandidate> candidates;         ///< ranked, as searched
  std::vector<VerificationResult> verifications;  ///< one per candidate tried
  std::vector<GateResult> gates;                  ///< one per verified candidate (drift gate)
  std::vector<LoopClosure> accepted;              ///< passed verification and the drift gate
  /// Loops accepted without their own reverse cross-check, as agreeing near-duplicates of a fully
  /// checked loop (LoopClosureConfig::light_duplicate_keyframes).
  std::size_t light_verifications = 0;
};

/// Keeps the keyframes (clouds in their sensor frames and their landmarks) and closes loops.
class LoopDetector {
 public:
  explicit LoopDetector(ClassTable classes, LoopClosureConfig config = {});

  /// Where evicted keyframe clouds come back from: the raw cloud of keyframe k (as given to
  /// addKeyframe; it is downsampled again). Without a loader every keyframe stays in memory.
  using CloudLoader = std::function<LabeledCloud(std::size_t keyframe)>;
  void setCloudLoader(CloudLoader loader) { loader_ = std::move(loader); }

  /// Adds a keyframe (cloud in its own sensor frame); returns its index.
  std::size_t addKeyframe(LabeledCloud cloud);
  std::size_t size() const { return clouds_.size(); }
  /// Keyframe k's verification cloud (downsampled), reloaded through the loader if evicted.
  std::shared_ptr<const LabeledCloud> cloud(std::size_t k) const;
  /// Keyframe clouds currently held in memory.
  std::size_t residentClouds() const;
  const std::vector<PropertyLandmark>& landmarks(std::size_t k) const { return landmarks_.at(k); }
  const std::vector<std::vector<PropertyLandmark>>& allLandmarks() const { return landmarks_; }
  /// The constellation keyframe k is matched with: its landmarks merged over landmark_window
  /// (partial-extent classes: over partial_landmark_window on each side, up to keyframe `newest`;
  /// default: the newest keyframe).
  std::vector<PropertyLandmark> placeLandmarks(std::size_t k, const PoseList& estimate) const;
  std::vector<PropertyLandmark> placeLandmarks(std::size_t k, std::size_t newest, const PoseList& estimate) const;
  /// True when some property class's labels are partial (ClassInfo::whole_extent false) and
  /// partial_landmark_window > 0: landmarks then come from the keyframe's neighbourhood on both sides.
  bool usesNeighbourhoodLandmarks() const { return neighbourhood_; }
  const LoopClosureConfig& config() const { return config_; }
  /// The verification target of keyframe k for a loop with `query`: keyframe k's cloud and its
  /// submap_keyframes neighbours on each side (at most query − min_index_gap), placed in k's frame
  /// with `estimate` (world ← keyframe) and downsampled to keyframe_voxel.
  LabeledCloud submap(std::size_t k, std::size_t query, const PoseList& estimate) const;
  /// The registration target built from submap(k, query, estimate), cached: rebuilt only when
  /// the submap's keyframes or their placement in k's frame changed (an optimisation moved them),
  /// so consecutive queries along an old path reuse the same target.
  std::shared_ptr<const RegistrationTarget> submapTarget(std::size_t k, std::size_t query,
                                                         const PoseList& estimate) const;
  std::size_t submapTargetsBuilt() const { return submap_targets_built_; }
  /// The query side of the reverse cross-check: keyframe `query` and the
  /// cross_check_query_keyframes keyframes before it, placed in query's frame with `estimate`
  /// and downsampled to keyframe_voxel.
  LabeledCloud querySubmap(std::size_t query, const PoseList& estimate) const;
  /// The reverse cross-check (verification.cross_check_chi2) of a forward loop answer T_from_to
  /// (match ← query) with covariance `forward_covariance`: the match submap registered onto
  /// querySubmap from the inverse of the candidate's guess; returns the χ² (6 dof) of the two
  /// answers' difference against twice the forward covariance plus the floors, NaN when the
  /// reverse registration fails. With cross_check_query_keyframes = 0: the two single scans.
  double crossCheckDistance(const LoopCandidate& cand, const PoseList& estimate, const Eigen::Isometry3d& T_from_to,
                            const Matrix6d& forward_covariance) const;

  /// Candidates for `query` by the configured method. `estimate` (world ← keyframe, at least
  /// query + 1 poses) is used by the distance search and, with landmark_window > 1, to merge
  /// the window's landmarks (locally only: drift between distant keyframes does not matter).
  std::vector<LoopCandidate> candidates(std::size_t query, const PoseList& estimate) const;

  /// Candidates → ICP verification → drift gate against `estimate`; accepted loops are also
  /// remembered for consistentLoops(). With neighbourhood landmarks (usesNeighbourhoodLandmarks)
  /// keyframe query − partial_landmark_window is searched too, its neighbourhood now complete
  /// (pairs already accepted are not tried again); its results follow the query's in the detection.
  LoopDetection detect(std::size_t query, const PoseList& estimate);

  /// Every loop accepted so far that belongs to the largest pairwise-consistent set under
  /// `estimate` (IncrementalConsistency: beyond 64 loops a pair once tested is remembered).
  std::vector<LoopClosure> consistentLoops(const PoseList& estimate) const;
  /// With this set, detect() gates verified loops by the calibrated innovation test
  /// (innovationGate) with the covariance the caller's pose graph gives the relative pose of two
  /// keyframes, instead of the drift model's gate.
  using RelativeCovariance = std::function<Matrix6d(std::size_t from, std::size_t to)>;
  void setRelativeCovariance(RelativeCovariance f) { relative_covariance_ = std::move(f); }
  /// Forgets an accepted loop (the back end dropped it, e.g. its optimisation failed).
  void dropLoop(std::size_t from, std::size_t to);
  const std::vector<LoopClosure>& acceptedLoops() const { return loops_; }

 private:
  ClassTable classes_;
  LoopClosureConfig config_;
  LabeledCloud prepare(LabeledCloud cloud) const;  ///< keyframe_voxel downsampling
  bool candidatePlausible(const LoopCandidate& cand, const PoseList& estimate, LoopDetection& det) const;
  /// Constellation candidates of `query` with neighbourhoods reaching at most keyframe `newest`.
  std::vector<LoopCandidate> constellationCandidates(std::size_t query, std::size_t newest, const PoseList& estimate) const;
  /// Neighbourhood candidates moved to the keyframe of the matched stretch nearest the query.
  std::vector<LoopCandidate> nearestInStretch(std::vector<LoopCandidate> candidates, const PoseList& estimate) const;
  /// Distance candidates too: method distance/both, or a sparse camera-label keyframe.
  bool wantsDistanceCandidates(std::size_t query, const PoseList& estimate) const;
  /// Verifies and gates the candidates into `det` (at most max_loops_per_keyframe accepted).
  void verifyInto(const std::vector<LoopCandidate>& candidates, const PoseList& estimate, LoopDetection& det);
  /// Returns whether the reverse cross-check agreed (the misfit term was dropped).
  bool crossCheck(const LoopCandidate& cand, const PoseList& estimate, VerificationResult& v) const;
  /// A loop accepted with the full checks: what its reverse cross-check concluded.
  struct CheckedLoop {
    std::size_t from = 0, to = 0;
    bool cross_check_agreed = false;
  };
  /// One candidate's verification: light (light_duplicate_keyframes) or full. `checked` is set
  /// when the full checks ran (the loop may serve as a light verification's reference).
  VerificationResult verifyOne(const LoopCandidate& cand, const PoseList& estimate, bool& light, CheckedLoop& checked);
  /// The fully checked accepted loop nearest cand at both ends within light_duplicate_keyframes.
  const CheckedLoop* checkedNeighbour(const LoopCandidate& cand) const;
  /// χ² (6 dof) of `loop` against `ref` composed with the estimate's short paths at both ends.
  double duplicateDistance2(const LoopClosure& loop, const LoopClosure& ref, const PoseList& estimate) const;
  /// Covariance of estimate[a]⁻¹ · estimate[b] (left perturbation in a): the graph's when set,
  /// else the drift model's.
  Matrix6d shortPathCovariance(std::size_t a, std::size_t b, const PoseList& estimate) const;
  std::vector<CheckedLoop> checked_;
  bool neighbourhood_ = false;
  std::vector<std::vector<PropertyLandmark>> whole_landmarks_, partial_landmarks_;  ///< landmarks_ split by class kind
  std::vector<std::shared_ptr<const LabeledCloud>> clouds_;  ///< null = evicted
  CloudLoader loader_;
  static constexpr std::size_t kReloadCache = 24;
  mutable std::deque<std::pair<std::size_t, std::shared_ptr<const LabeledCloud>>> reloaded_;
  RelativeCovariance relative_covariance_;
  struct CachedSubmap {
    std::size_t k = 0, first = 0, last = 0;
    std::vector<Eigen::Isometry3d> placement;  ///< k ← j for j in [first, last]
    std::shared_ptr<const RegistrationTarget> target;
  };
  static constexpr std::size_t kSubmapCache = 16;
  mutable std::deque<CachedSubmap> submaps_;
  mutable std::size_t submap_targets_built_ = 0;
  std::vector<std::vector<PropertyLandmark>> landmarks_;
  std::vector<LoopClosure> loops_;
  mutable IncrementalConsistency consistency_;  ///< pair tests of loops_ remembered beyond 64 loops
};

/// Whether a loop agrees with ground truth (`truth` = world ← keyframe): its relative pose is
/// within the given translation (m) and rotation (rad) error of the true one.
bool isTrueLoop(const LoopClosure& loop, const PoseList& truth, double max_translation_error = 0.5,
                double max_rotation_error = 0.05);

}  // namespace hazmap
