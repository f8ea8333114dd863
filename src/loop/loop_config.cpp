// LoopClosureConfig and its parts: their field tables (core/config_fields.hpp) and the YAML entry
// points and validate() functions derived from them.
#include <cmath>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/loop/loop_closure.hpp"

namespace hazmap {

const char* toString(CandidateMethod method) {
  switch (method) {
    case CandidateMethod::Constellation: return "constellation";
    case CandidateMethod::Distance: return "distance";
    case CandidateMethod::Both: return "both";
  }
  return "constellation";
}

const ConfigFields<LandmarkConfig>& configFields(ConfigTag<LandmarkConfig>) {
  using C = LandmarkConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Property landmarks: same-class clusters of labelled points.")
          .number("cluster_tolerance", &C::cluster_tolerance, positive(),
                  "m; same-class points closer than this join one landmark")
          .integer("min_points", &C::min_points, atLeast(1), "Smaller clusters are label noise")
          .number("max_range", &C::max_range, nonNegative(), "m; farther points are ignored (0 = no limit)")
          .number("min_purity", &C::min_purity, closed(0, 1),
                  "Share of all points in the cluster's cells that it must make up (0 = off)");
  return fields;
}

const ConfigFields<ConstellationConfig>& configFields(ConfigTag<ConstellationConfig>) {
  using C = ConstellationConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Constellation matching of two keyframes' landmarks (RANSAC over pairs or triples).")
          .choice("model", &C::model, {{"planar", ConstellationModel::Planar}, {"full-3d", ConstellationModel::Full3D}},
                  "planar: x, y, yaw from landmark pairs; full-3d: 6-DoF from triples")
          .number("inlier_distance", &C::inlier_distance, positive(), "m; inlier radius after the hypothesis")
          .integer("min_inliers", &C::min_inliers, atLeast(2), "Matched landmarks needed for a candidate")
          .number("property_value_tolerance", &C::property_value_tolerance, nonNegative(),
                  "Gate on the mean property value (0 = off)")
          .integer("seed", &C::seed, nonNegative(), "Seed of the hypotheses sample beyond its cap")
          .number("facing_tolerance", &C::facing_tolerance, closed(0, M_PI),
                  "rad; matched flat landmarks must face the same way (0 = off)")
          .rule("min_inliers",
                [](const C& c) { return c.model != ConstellationModel::Full3D || c.min_inliers >= 3; },
                "must be >= 3 for the full-3d model");
  return fields;
}

const ConfigFields<CandidateSearchConfig>& configFields(ConfigTag<CandidateSearchConfig>) {
  using C = CandidateSearchConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Loop candidates: which past keyframe the current one may re-observe.")
          .integer("min_index_gap", &C::min_index_gap, nonNegative(),
                   "Keyframes newer than query − gap are never candidates")
          .number("search_radius", &C::search_radius, positive(), "m; distance search radius")
          .integer("max_candidates", &C::max_candidates, atLeast(1), "Candidates per query, best first")
          .section("constellation", &C::constellation, "");
  return fields;
}

RegistrationConfig VerificationIcpOverrides::over(RegistrationConfig tracking) const {
  tracking.max_correspondence_distance = max_correspondence_distance;
  tracking.max_iterations = max_iterations;
  tracking.max_source_points = max_source_points;
  tracking.index = index;
  tracking.coarse_source_points = coarse_source_points;
  return tracking;
}

const ConfigFields<VerificationIcpOverrides>& configFields(ConfigTag<VerificationIcpOverrides>) {
  using C = VerificationIcpOverrides;
  static const ConfigFields<C> fields =
      ConfigFields<C>("What the verification ICP changes from tracking's (odometry.registration); "
                      "every other setting is tracking's.")
          .number("max_correspondence_distance", &C::max_correspondence_distance, positive(),
                  "m; search radius of unlabelled points (loops start farther from the truth than odometry steps)")
          .integer("max_iterations", &C::max_iterations, atLeast(1), "Iteration limit")
          .integer("max_source_points", &C::max_source_points, nonNegative(),
                   "Use at most this many source points, evenly strided (0 = all)")
          .choice("index", &C::index,
                  {{"voxel", SpatialIndexKind::VoxelHash}, {"kdtree", SpatialIndexKind::KdTree},
                   {"voxel-hash", SpatialIndexKind::VoxelHash}, {"k-d tree", SpatialIndexKind::KdTree}},
                  "Spatial index of the target (dense submaps searched wide: the k-d tree is faster)")
          .integer("coarse_source_points", &C::coarse_source_points, nonNegative(),
                   "Coarse to fine stage of the verification ICP (0 = single stage, as the acceptance thresholds were set)");
  return fields;
}

const ConfigFields<VerificationConfig>& configFields(ConfigTag<VerificationConfig>) {
  using C = VerificationConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Loop verification: ICP from the candidate's guess, then acceptance rules.")
          .number("min_fitness", &C::min_fitness, closed(0, 1), "Fraction of source points with a partner")
          .number("max_rmse", &C::max_rmse, positive(), "m; inlier RMSE")
          .flag("reject_degenerate", &C::reject_degenerate, "Reject loops with a degenerate direction")
          .number("max_correction_translation", &C::max_correction_translation, positive(),
                  "m; ICP may move the guess at most this far")
          .number("max_correction_rotation", &C::max_correction_rotation, positive(), "rad")
          .number("covariance_scale", &C::covariance_scale, positive(),
                  "Calibration: the ICP covariance is multiplied by this before the floors (fitted by NEES)")
          .number("misfit_scale", &C::misfit_scale, nonNegative(),
                  "Adds this × inlier_rmse² · H⁻¹ (the whole misfit along the Hessian's weak axes) to the loop covariance (0 = off)")
          .number("cross_check_chi2", &C::cross_check_chi2, nonNegative(),
                  "χ²; the misfit term is dropped for a loop whose reverse registration agrees to within this (0 = off)")
          .number("label_only_sigma", &C::label_only_sigma, nonNegative(),
                  "m; standard deviation added along directions only labelled patches constrain; the default removes the loop's information there (0 = off)")
          .number("probe_distance", &C::probe_distance, nonNegative(),
                  "m; basin probes: ICP again from ±this along x and y, their spread joins the covariance (0 = off)")
          .integer("coarse_source_points", &C::coarse_source_points, atLeast(0),
                   "Coarse check first with this many source points; rejects candidates far below min_fitness cheaply (0 = off)")
          .number("coarse_fitness_margin", &C::coarse_fitness_margin, nonNegative(),
                  "The coarse check rejects below min_fitness − this")
          .integer("guess_check_points", &C::guess_check_points, atLeast(0),
                   "Fitness of this many source points at the guess (one search, no ICP) before the coarse check (0 = off)")
          .number("full_from_coarse_within", &C::full_from_coarse_within, nonNegative(),
                  "m (translation + 10 m × rotation); the full verification ICP starts where the coarse check converged when that lies within this of the guess (0 = always from the guess)")
          .integer("probe_coarse_points", &C::probe_coarse_points, atLeast(0),
                   "Basin probes and the reverse cross-check start with a coarse stage on this many source points, then refine on all (0 = single stage)")
          .number("probe_tolerance_scale", &C::probe_tolerance_scale, atLeast(1.0),
                  "Basin probes stop at the registration's tolerances times this (1 = the verification's)")
          .section("registration", &C::registration,
                   "The verification ICP: overrides of odometry.registration (α and class radii: property_icp)");
  return fields;
}

const ConfigFields<ConsistencyConfig>& configFields(ConfigTag<ConsistencyConfig>) {
  using C = ConsistencyConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Rejection of false loops: drift gate and pairwise consistency.")
          .number("translation_drift_per_metre", &C::translation_drift_per_metre, nonNegative(),
                  "Drift model: m per m of path")
          .number("rotation_drift_per_metre", &C::rotation_drift_per_metre, nonNegative(), "rad per m")
          .number("gate_probability", &C::gate_probability, Range{0.0, 1.0, true, true},
                  "Probability of the χ² gates (6 degrees of freedom)");
  return fields;
}

const ConfigFields<LoopClosureConfig>& configFields(ConfigTag<LoopClosureConfig>) {
  using C = LoopClosureConfig;
  static const ConfigFields<C> fields =
      ConfigFields<C>("Loop closure from property landmarks (paper section V).")
          .choice("method", &C::method,
                  {{"constellation", CandidateMethod::Constellation}, {"distance", CandidateMethod::Distance},
                   {"both", CandidateMethod::Both}},
                  "Candidate search: property constellations, distance in the estimate, or both")
          .integer("max_loops_per_keyframe", &C::max_loops_per_keyframe, atLeast(1), "Verified loops kept per query")
          .number("keyframe_voxel", &C::keyframe_voxel, nonNegative(),
                  "m; keyframe clouds are stored downsampled to this (0 = every point)")
          .integer("resident_keyframes", &C::resident_keyframes, atLeast(1),
                   "Keyframe clouds kept in memory (older ones are reloaded)")
          .integer("landmark_window", &C::landmark_window, atLeast(1),
                   "Constellations merge the landmarks of this many keyframes")
          .number("landmark_merge_distance", &C::landmark_merge_distance, positive(),
                  "m; same-class landmarks closer than this fuse")
          .integer("partial_landmark_window", &C::partial_landmark_window, atLeast(0),
                   "Classes labelled only in part (camera labels) take their landmarks from this many keyframes on each side (0 = as the others)")
          .flag("partial_nearest_keyframe", &C::partial_nearest_keyframe,
                "Candidates from such neighbourhoods are verified at the matched stretch's keyframes nearest the query (false: the keyframe the constellation named)")
          .integer("partial_distance_below_landmarks", &C::partial_distance_below_landmarks, atLeast(0),
                   "With camera labels, a keyframe whose constellation holds fewer landmarks than this also takes distance candidates from the estimate (0 = off)")
          .integer("submap_keyframes", &C::submap_keyframes, atLeast(0),
                   "Loops are verified against the matched keyframe and this many neighbours on each side (0 = its scan alone)")
          .integer("cross_check_query_keyframes", &C::cross_check_query_keyframes, atLeast(0),
                   "The reverse cross-check registers the match submap onto the query keyframe and this many keyframes before it (0 = the two scans alone)")
          .number("submap_reuse_tolerance", &C::submap_reuse_tolerance, nonNegative(),
                  "m; a cached verification submap is reused while its keyframes moved less than this (translation + 10 m × rotation; 0 = only when placed identically)")
          .integer("light_duplicate_keyframes", &C::light_duplicate_keyframes, atLeast(0),
                   "A verified candidate within this many keyframes (both ends) of a fully checked loop whose answer agrees with it skips the reverse cross-check and takes over that loop's verdict (online cost; 0 = off)")
          .section("landmarks", &C::landmarks, "")
          .section("candidates", &C::candidates, "")
          .section("verification", &C::verification, "")
          .section("consistency", &C::consistency, "");
  return fields;
}

void validate(const LandmarkConfig& c) { validateConfig(c, "loop_closure.landmarks"); }
void validate(const CandidateSearchConfig& c) { validateConfig(c, "loop_closure.candidates"); }
void validate(const VerificationConfig& c) { validateConfig(c, "loop_closure.verification"); }
void validate(const ConsistencyConfig& c) { validateConfig(c, "loop_closure.consistency"); }
void LoopClosureConfig::validate() const { validateConfig(*this, "loop_closure"); }

LoopClosureConfig LoopClosureConfig::fromYamlFile(const std::filesystem::path& path) {
  return fromYamlString(readTextFile(path), path.string());
}

LoopClosureConfig LoopClosureConfig::fromYamlString(const std::string& yaml, const std::string& where) {
  return configFromYaml(yaml, where, "loop_closure", LoopClosureConfig{});
}

std::string LoopClosureConfig::toYamlString() const { return configToYaml(*this, "loop_closure"); }

}  // namespace hazmap
