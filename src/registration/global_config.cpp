// GlobalRegistrationConfig: its field table (core/config_fields.hpp) and YAML entry points.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/registration/global_registration.hpp"

namespace hazmap {

const char* toString(GlobalStatus s) {
  switch (s) {
    case GlobalStatus::Success: return "success";
    case GlobalStatus::TooFewPoints: return "too few points";
    case GlobalStatus::TooFewFeatures: return "too few features";
    case GlobalStatus::TooFewCorrespondences: return "too few correspondences";
    case GlobalStatus::NoConsensus: return "no consensus";
    case GlobalStatus::PoorOverlap: return "poor overlap";
    case GlobalStatus::Ambiguous: return "ambiguous";
    case GlobalStatus::Degenerate: return "degenerate";
    case GlobalStatus::LabelsDisagree: return "labels disagree";
  }
  return "unknown";
}

RegistrationConfig RefinementIcpOverrides::over(RegistrationConfig tracking) const {
  tracking.max_iterations = max_iterations;
  tracking.max_source_points = max_source_points;
  tracking.coarse_source_points = coarse_source_points;
  return tracking;
}

const ConfigFields<RefinementIcpOverrides>& configFields(ConfigTag<RefinementIcpOverrides>) {
  using R = RefinementIcpOverrides;
  static const ConfigFields<R> fields =
      ConfigFields<R>("What the refinement ICP changes from tracking's (odometry.registration); every "
                      "other setting is tracking's.")
          .integer("max_iterations", &R::max_iterations, atLeast(1), "Iteration limit")
          .integer("max_source_points", &R::max_source_points, nonNegative(),
                   "Use at most this many source points, evenly strided (0 = all)")
          .integer("coarse_source_points", &R::coarse_source_points, nonNegative(),
                   "Coarse to fine stage (0 = off: the downsampled scan is small already)");
  return fields;
}

namespace {

using C = GlobalRegistrationConfig;

void addFeatureFields(ConfigFields<C>& f) {
  f.number("voxel_size", &C::voxel_size, positive(), "m; both clouds are downsampled to this first")
      .number("normal_radius", &C::normal_radius, positive(), "m; neighbourhood of the normals")
      .integer("normal_neighbors", &C::normal_neighbors, atLeast(3), "k nearest points per normal")
      .number("feature_radius", &C::feature_radius, positive(), "m; FPFH neighbourhood (≈ 5 voxels)")
      .integer("max_feature_neighbors", &C::max_feature_neighbors, atLeast(5),
               "Neighbours per FPFH histogram, nearest first")
      .number("max_range", &C::max_range, nonNegative(), "m from the cloud's origin; farther points ignored (0 = all)")
      .integer("max_source_features", &C::max_source_features, nonNegative(),
               "Match at most this many source descriptors (even stride, labelled points always; 0 = all)")
      .flag("mutual_filter", &C::mutual_filter,
            "Keep only mutual nearest neighbours in descriptor space (when at least min_correspondences)")
      .integer("min_correspondences", &C::min_correspondences, atLeast(3),
               "Mutual matches needed before the filter is trusted");
}

void addEstimatorFields(ConfigFields<C>& f) {
  f.integer("ransac_iterations", &C::ransac_iterations, atLeast(1), "Triples drawn (fixed count: deterministic)")
      .number("edge_length_similarity", &C::edge_length_similarity, closedOpen(0, 1),
              "Pre-check: every edge-length ratio of a triple must be >= this")
      .number("inlier_distance", &C::inlier_distance, positive(), "m; a match or point agrees within this")
      .integer("seed", &C::seed, nonNegative(), "RANSAC seed (the result does not depend on threads)")
      .flag("use_classes", &C::use_classes,
            "Property-aware: labelled points match their own class, landmark constellations add "
            "hypotheses, labelled points on their class score more (also sets refinement.use_classes)")
      .number("label_score_share", &C::label_score_share, closed(0, 1),
              "Score = (1 − share)·overlap + share·(labelled points on their own class / labelled points)")
      .integer("min_labelled_points", &C::min_labelled_points, atLeast(1),
               "Labelled (downsampled) source points in landmarks needed for the label term of the score")
      .number("min_label_agreement", &C::min_label_agreement, closed(0, 1),
              "Refuse a winner on which fewer labelled points land on their own class than this share")
      .number("landmark_cluster_distance", &C::landmark_cluster_distance, positive(),
              "m; same-class points closer than this form one landmark")
      .integer("landmark_min_points", &C::landmark_min_points, atLeast(1), "Downsampled points per landmark");
}

void addVerificationFields(ConfigFields<C>& f) {
  f.integer("min_points", &C::min_points, atLeast(3), "Downsampled source/target points needed")
      .integer("min_features", &C::min_features, atLeast(3), "Points with a descriptor needed")
      .number("min_overlap", &C::min_overlap, closed(0, 1),
              "Refined share of source points with a target point within inlier_distance")
      .number("ambiguity_ratio", &C::ambiguity_ratio, openClosed(0, 1),
              "A distinct second hypothesis scoring >= ratio × best makes the result ambiguous")
      .number("distinct_translation", &C::distinct_translation, positive(),
              "m; hypotheses farther apart are distinct")
      .number("distinct_rotation_deg", &C::distinct_rotation_deg, positive(), "degrees; … or rotated more")
      .flag("reject_degenerate", &C::reject_degenerate,
            "Refuse a winner whose refinement ICP reports unconstrained directions (a plane, a bare corridor)")
      .integer("candidates_refined", &C::candidates_refined, atLeast(1), "Distinct hypotheses refined by ICP")
      .number("final_voxel_size", &C::final_voxel_size, nonNegative(),
              "m; the winner is polished by the refinement ICP on clouds downsampled to this (0 = off)")
      .integer("threads", &C::threads, nonNegative(), "0 = TBB's default")
      .section("refinement", &C::refinement, "Property ICP that refines and verifies the candidates");
}

ConfigFields<C> makeFields() {
  ConfigFields<C> f("Global registration without an initial guess: FPFH features, RANSAC and property-landmark "
                    "constellations, verified by property ICP (docs/registration.md).");
  addFeatureFields(f);
  addEstimatorFields(f);
  addVerificationFields(f);
  f.rule("feature_radius", [](const C& c) { return c.feature_radius > c.voxel_size; },
         "must be larger than voxel_size");
  return f;
}

}  // namespace

const ConfigFields<GlobalRegistrationConfig>& configFields(ConfigTag<GlobalRegistrationConfig>) {
  static const ConfigFields<GlobalRegistrationConfig> fields = makeFields();
  return fields;
}

void GlobalRegistrationConfig::validate() const { validateConfig(*this, "global_registration"); }

GlobalRegistrationConfig globalRegistrationConfigFromYaml(const std::string& yaml, const std::string& where,
                                                          const GlobalRegistrationConfig& base) {
  return configFromYaml(yaml, where, "global_registration", base);
}

GlobalRegistrationConfig loadGlobalRegistrationConfig(const std::string& path, const GlobalRegistrationConfig& base) {
  return globalRegistrationConfigFromYaml(readTextFile(path), path, base);
}

}  // namespace hazmap
