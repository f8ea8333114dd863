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
      .number("max_range", &C::max_range, nonNegative(), "m from the cloud's origin; farther points ignored (0 = all)");
}

void addEstimatorFields(ConfigFields<C>& f) {
  f.integer("ransac_iterations", &C::ransac_iterations, atLeast(1), "Triples drawn (fixed count: deterministic)")
      .number("inlier_distance", &C::inlier_distance, positive(), "m; a match or point agrees within this")
      .integer("seed", &C::seed, nonNegative(), "RANSAC seed (the result does not depend on threads)")
      .flag("use_classes", &C::use_classes,
            "Property-aware: labelled points match their own class, landmark constellations add "
            "hypotheses, labelled points on their class score more (also sets the refinement's use_classes)");
}

void addVerificationFields(ConfigFields<C>& f) {
  f.number("min_overlap", &C::min_overlap, closed(0, 1),
           "Refined share of source points with a target point within inlier_distance")
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
