#pragma once
// Property-aware ICP (paper section IV, eq. 2) with pose covariance. Plain ICP is the same code
// with use_classes = false (α = 0 and one search radius for every point).
//
// Correspondence rule (eq. 2): a source point p of class c(p) is paired with the target point q
// minimising d²(p, q) + λ(p, q), λ = α when the classes differ, 0 when they agree. Candidates of
// the same class are searched within the class's search radius (ClassInfo::search_radius, wider
// for property classes, 0 = max_correspondence_distance); candidates of other classes within
// max_correspondence_distance. The gate is geometric, the ranking penalised. See
// docs/registration.md for the details, the beyond-the-paper options and the covariance.
#include <Eigen/Geometry>
#include <limits>
#include <cstddef>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"

namespace hazmap {

enum class IcpMetric { PointToPoint, PointToPlane };
enum class RobustKernel { None, Huber, GemanMcClure };
enum class LabelMode {
  Hard,  ///< the paper: mismatch costs α, mismatched pairs count fully in the objective
  Soft,  ///< labels are right with probability `label_confidence`: mismatch costs α·c², and
         ///< a mismatched pair's residual weight is discounted by (1 − c²) (SuMa++-like)
};
enum class SpatialIndexKind {
  VoxelHash,  ///< sparse voxel grid, exact radius-bounded search (default; faster, see bench)
  KdTree,     ///< nanoflann k-d tree per class (kept for the comparison)
};

const char* toString(IcpMetric m);
const char* toString(RobustKernel k);
const char* toString(LabelMode m);
const char* toString(SpatialIndexKind k);

struct RegistrationConfig {
  bool use_classes = true;                ///< false = conventional ICP
  IcpMetric metric = IcpMetric::PointToPlane;
  double max_correspondence_distance = 1.0;  ///< m, for unlabelled points (> 0)
  int max_iterations = 50;                   ///< >= 1

  // --- the paper's penalty: α is ClassTable::mismatch_penalty and the wider same-class search
  // radii are ClassInfo::search_radius, set once for tracking and loop verification alike
  // (PropertyIcpConfig, the `property_icp:` section and --mismatch-penalty / --class-radius) ---
  LabelMode label_mode = LabelMode::Hard;
  double label_confidence = 0.9;  ///< soft mode: probability that a label is right, (0, 1]
  /// Multiply a pair's residual weight by ClassInfo::weight of the source point's class.
  bool use_class_weights = true;
  /// Continuous property (LabeledCloud::property, e.g. °C): adds property_weight·(v_p − v_q)²
  /// (m² per unit²) to the matching cost when both clouds have the channel; 0 = off.
  double property_weight = 0.0;
  /// Point-to-plane only: a property point matched to its own class gets a 3-D (point-to-point)
  /// residual — a labelled patch usually lies in its wall, so its plane residual would not say
  /// where along the wall it is, which is exactly what the label tells.
  bool property_point_to_point = true;
  /// Weight (0…1) of that 3-D residual's in-plane part relative to its along-normal part, when
  /// the target point has a normal. In-plane, a labelled point and its same-class partner are
  /// apart mostly because the two scans hit the patch at different spots (σ ≈ 0.2 m against
  /// ≈ 0.03 m along the normal, hence (0.03/0.2)² ≈ 0.02): at full weight that sampling noise
  /// biases well-constrained scans. Along directions the rest of the residuals leave degenerate
  /// (a corridor's axis; same test as degenerate_directions) the in-plane part gets full weight,
  /// because there it is the only information. 1 = plain 3-D residual everywhere.
  double property_tangent_weight = 0.02;
  /// Label gate: at the initial guess, the labelled source points' agreement with the class of
  /// their nearest target point, corrected for chance (Cohen's κ: 1 = always agree, 0 = no better
  /// than the target's class shares). Below this the registration ignores the labels (runs as
  /// plain ICP) and says so in RegistrationResult::labels_used. <= -1 = never ignore them.
  double min_label_agreement = 0.3;
  /// The gate decides only with at least this many labelled source points paired (else labels
  /// are used: a handful cannot pull the estimate far).
  std::size_t min_label_pairs = 20;

  // --- robust kernel with adaptive threshold ---
  RobustKernel robust_kernel = RobustKernel::GemanMcClure;
  /// Kernel scale = max(robust_min_scale, robust_scale_factor · 1.4826 · median |residual|),
  /// re-estimated every iteration from the observed residuals.
  double robust_scale_factor = 3.0;
  double robust_min_scale = 0.01;  ///< m

  // --- convergence ---
  double translation_tolerance = 1e-4;  ///< m; stop when the update is below both tolerances
  double rotation_tolerance = 1e-4;     ///< rad
  /// Keep the correspondences for the next iteration while no source point has moved more than
  /// this (m, summed since they were searched) — only the robust weights and the linearisation
  /// are redone. The robust kernel's reweighting converges slowly (linearly) in sub-millimetre
  /// steps whose searches would return the same partners; convergence is only declared on
  /// fresh correspondences. 0 = search every iteration.
  double correspondence_reuse_distance = 0.05;
  std::size_t min_correspondences = 10;  ///< fewer → converged=false, reason given

  // --- point-to-plane normals (target) ---
  int normal_neighbors = 10;     ///< k nearest target points used for each normal (>= 3)
  double normal_radius = 1.0;    ///< m, neighbours farther away are ignored

  // --- speed ---
  SpatialIndexKind index = SpatialIndexKind::VoxelHash;
  /// Voxel edge of the hash index for unlabelled points (m); 0 = max_correspondence_distance
  /// (measured fastest on the scan pair; see docs/registration.md).
  double index_cell_size = 0.0;
  /// Use at most this many source points (evenly strided, deterministic); 0 = all.
  std::size_t max_source_points = 0;
  /// Coarse to fine: a source of at least 4× this many points is first registered with only this
  /// many of them (evenly strided) to tolerances 10× looser, and the full source then refines
  /// from there — the early steps, which move far, cost a fraction, and the answer is the full
  /// source's (measured within 1 mm / 0.04° of a full-only run on the scan pair and KITTI).
  /// Each stage has max_iterations. 0 = off. Sparse scans (a VLP-16 frame at 0.5 m, ~1.4k
  /// points) stay single-stage.
  std::size_t coarse_source_points = 1000;
  int threads = 0;  ///< 0 = TBB's default (or the surrounding tbb::global_control)

  // --- covariance / degeneracy ---
  /// A direction of the Hessian (rotations scaled by degeneracy_length) whose eigenvalue is below
  /// this fraction of the pairs' total weight is reported as degenerate (see covariance.hpp).
  double degeneracy_threshold = 0.01;
  double degeneracy_length = 1.0;  ///< m: a rotation θ weighs like a translation θ·length

  /// Throws hazmap::Error naming the offending parameter ("registration.<key>: ...").
  void validate() const;
  /// The α actually used: the class table's (0 when use_classes=false).
  double effectiveMismatchPenalty(const ClassTable& classes) const;
};

/// The field table (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<RegistrationConfig>& configFields(ConfigTag<RegistrationConfig>);

/// Reads a YAML mapping (keys = field names above, at top level or under `registration:`; enums
/// as text: metric point|plane, robust_kernel none|huber|geman-mcclure, label_mode hard|soft,
/// index voxel|kdtree). Unknown keys are an error. `base` supplies the values of absent keys.
RegistrationConfig registrationConfigFromYaml(const std::string& yaml, const std::string& where,
                                              const RegistrationConfig& base = {});
RegistrationConfig loadRegistrationConfig(const std::string& path,
                                          const RegistrationConfig& base = {});
std::string toYamlString(const RegistrationConfig& config);

/// How the labels shaped the final correspondences (beyond the paper; for reports). Counted for
/// plain ICP too (classes looked at, not used), so the two can be compared.
struct CorrespondenceStats {
  std::size_t source_points = 0;     ///< points used (after max_source_points)
  std::size_t matched = 0;           ///< with a correspondence
  std::size_t same_class = 0;        ///< matched to a point of the same class
  std::size_t cross_class = 0;       ///< matched to a point of another class (penalised)
  std::size_t property_points = 0;   ///< source points of a property class
  std::size_t property_matched = 0;  ///< … of which matched to their own class
  /// property points matched beyond max_correspondence_distance (only the wider radius allowed it)
  std::size_t wide_matches = 0;
};

/// How a registration ended. `RegistrationResult::reason` says the same for people.
enum class Termination {
  NotRun,                  ///< no registration ran (e.g. no target yet)
  Converged,               ///< a step below the tolerances on fresh correspondences
  MaxIterations,           ///< max_iterations searches without converging (the pose is usable)
  EmptySource,             ///< no finite source point
  EmptyTarget,             ///< no target point
  TooFewSourcePoints,      ///< fewer finite source points than min_correspondences
  TooFewCorrespondences,   ///< a search found fewer pairs than min_correspondences
  AllRejected,             ///< the robust kernel gave every pair zero weight
  StepNotFinite,           ///< the Gauss–Newton step was not finite
  Diverged,                ///< the estimate became non-finite
};
const char* toString(Termination termination);

struct RegistrationResult {
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();  ///< target ← source
  Matrix6d covariance = Matrix6d::Identity();  ///< translation-first (see core/se3.hpp)
  double fitness = 0.0;       ///< fraction of source points with a correspondence
  double inlier_rmse = 0.0;   ///< m
  int iterations = 0;  ///< correspondence searches of the full-source stage
  int coarse_iterations = 0;  ///< … of the coarse stage (0 = none ran; see coarse_source_points)
  bool converged = false;
  std::vector<Vector6d> degenerate_directions;  ///< unit tangent directions, translation-first
  /// Directions the geometry (plane residuals, along-normal parts) leaves degenerate and only the
  /// labelled pairs' in-plane parts constrain (the test of property_tangent_weight; unit,
  /// translation-first; point-to-plane only). Along them the covariance rests on where two scans
  /// happened to sample a labelled patch, which the sandwich estimate does not see.
  std::vector<Vector6d> label_only_directions;
  Termination termination = Termination::NotRun;
  std::string reason;  ///< why it did not converge, for people (empty when converged)
  // --- additions ---
  CorrespondenceStats stats;
  Matrix6d hessian = Matrix6d::Zero();  ///< Σ w JᵀJ at the solution (translation-first)
  double residual_sigma = 0.0;          ///< m, estimated residual standard deviation
  double kernel_scale = 0.0;            ///< m, final adaptive robust-kernel scale
  /// Label gate (see RegistrationConfig::min_label_agreement): chance-corrected agreement, NaN
  /// when not measured (plain ICP, or too few labelled points), and whether labels were used.
  double label_agreement = std::numeric_limits<double>::quiet_NaN();
  bool labels_used = false;
};

class RegistrationTarget;

/// Aligns `source` to `target` starting from `initial_guess` (target ← source).
/// Throws hazmap::Error for an invalid config, a non-finite initial guess or a class that is not in
/// `classes`. Empty or too small clouds give converged=false with `reason` and transform =
/// initial_guess. Non-finite points are ignored.
RegistrationResult registerClouds(const LabeledCloud& source, const LabeledCloud& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config = {});

/// Same, against a prebuilt target (indexes + normals), for repeated registrations against the
/// same cloud or local map. `target` must have been built with the same classes and a config
/// whose use_classes/metric/index/radii match (checked).
RegistrationResult registerClouds(const LabeledCloud& source, const RegistrationTarget& target,
                                  const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                  const RegistrationConfig& config = {});

/// Preprocessing + registration of two raw scans: each is voxel-downsampled with `downsample`
/// (classes kept by its vote) and the results registered as by registerClouds — same answer, bit
/// for bit. Faster with several threads: the source's downsampling runs alongside the target's
/// downsampling, indexing and normals, since a downsampling has a serial pass that leaves the
/// other cores idle. Throws as registerClouds, and for an invalid `downsample`.
RegistrationResult registerScans(const LabeledCloud& source, const LabeledCloud& target,
                                 const Eigen::Isometry3d& initial_guess, const ClassTable& classes,
                                 const VoxelDownsampleConfig& downsample,
                                 const RegistrationConfig& config = {});

}  // namespace hazmap
