// RegistrationConfig: its field table (core/config_fields.hpp) — the one place that names each
// setting, its range and its meaning — and the YAML/JSON entry points derived from it.
#include "hazmap/core/config_fields.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {

const char* toString(IcpMetric m) { return m == IcpMetric::PointToPoint ? "point" : "plane"; }
const char* toString(RobustKernel k) {
  switch (k) {
    case RobustKernel::None: return "none";
    case RobustKernel::Huber: return "huber";
    case RobustKernel::GemanMcClure: return "geman-mcclure";
  }
  return "none";
}
const char* toString(LabelMode m) { return m == LabelMode::Hard ? "hard" : "soft"; }
const char* toString(SpatialIndexKind k) { return k == SpatialIndexKind::VoxelHash ? "voxel" : "kdtree"; }

namespace {

using C = RegistrationConfig;

ConfigFields<C> makeFields() {
  ConfigFields<C> f("Property-aware ICP (paper eq. 2): correspondence search, robust kernel, "
                    "convergence, normals, covariance. α and the class search radii are the class "
                    "table's (section property_icp).");
  f.flag("use_classes", &C::use_classes, "Property ICP (true) or conventional ICP (false)")
      .choice("metric", &C::metric,
              {{"plane", IcpMetric::PointToPlane}, {"point", IcpMetric::PointToPoint},
               {"point-to-plane", IcpMetric::PointToPlane}, {"point-to-point", IcpMetric::PointToPoint}},
              "Residual: point-to-plane or point-to-point")
      .number("max_correspondence_distance", &C::max_correspondence_distance, positive(),
              "m; search radius of unlabelled points")
      .integer("max_iterations", &C::max_iterations, atLeast(1), "Iteration limit (per stage)")
      .choice("label_mode", &C::label_mode, {{"hard", LabelMode::Hard}, {"soft", LabelMode::Soft}},
              "hard: a class mismatch costs α (the paper); soft: α·c² and the pair is discounted by 1 − c²")
      .number("label_confidence", &C::label_confidence, openClosed(0, 1),
              "Soft mode: probability c that a label is right")
      .flag("use_class_weights", &C::use_class_weights,
            "Multiply a pair's weight by the class table's weight of the source point's class")
      .number("property_weight", &C::property_weight, nonNegative(),
              "m² per unit²; adds weight·(v_p − v_q)² of the continuous property channel (0 = off)")
      .flag("property_point_to_point", &C::property_point_to_point,
            "Point-to-plane: a property point matched to its own class gets a 3-D residual")
      .number("property_tangent_weight", &C::property_tangent_weight, closed(0, 1),
              "Weight of that residual's in-plane part (1 = plain 3-D residual)")
      .number("min_label_agreement", &C::min_label_agreement, atMost(1),
              "Label gate: Cohen's κ of the labels at the initial guess below which labels are "
              "ignored (<= -1 = never ignore them)")
      .integer("min_label_pairs", &C::min_label_pairs, nonNegative(),
               "The label gate decides only with at least this many labelled pairs")
      .choice("robust_kernel", &C::robust_kernel,
              {{"geman-mcclure", RobustKernel::GemanMcClure}, {"huber", RobustKernel::Huber},
               {"none", RobustKernel::None}, {"gm", RobustKernel::GemanMcClure}},
              "Robust kernel on the residuals")
      .number("robust_scale_factor", &C::robust_scale_factor, positive(),
              "Kernel scale = max(robust_min_scale, factor · 1.4826 · median |residual|)")
      .number("robust_min_scale", &C::robust_min_scale, positive(), "m; floor of the kernel scale")
      .number("translation_tolerance", &C::translation_tolerance, nonNegative(),
              "m; converged when the update is below both tolerances")
      .number("rotation_tolerance", &C::rotation_tolerance, nonNegative(), "rad")
      .number("correspondence_reuse_distance", &C::correspondence_reuse_distance, nonNegative(),
              "m; keep the correspondences while no source point moved more than this (0 = search "
              "every iteration)")
      .integer("min_correspondences", &C::min_correspondences, atLeast(6),
               "Fewer pairs = not converged (six unknowns)")
      .integer("normal_neighbors", &C::normal_neighbors, atLeast(3), "k nearest target points per normal")
      .number("normal_radius", &C::normal_radius, positive(), "m; farther neighbours are ignored")
      .choice("index", &C::index,
              {{"voxel", SpatialIndexKind::VoxelHash}, {"kdtree", SpatialIndexKind::KdTree},
               {"voxel-hash", SpatialIndexKind::VoxelHash}, {"k-d tree", SpatialIndexKind::KdTree}},
              "Spatial index of the target")
      .number("index_cell_size", &C::index_cell_size, nonNegative(),
              "m; voxel edge of the hash index (0 = max_correspondence_distance)")
      .integer("max_source_points", &C::max_source_points, nonNegative(),
               "Use at most this many source points, evenly strided (0 = all)")
      .integer("coarse_source_points", &C::coarse_source_points, nonNegative(),
               "Coarse to fine: a source of >= 4× this many points first converges on this many "
               "(0 = off)")
      .integer("threads", &C::threads, nonNegative(), "0 = TBB's default")
      .number("degeneracy_threshold", &C::degeneracy_threshold, closedOpen(0, 1),
              "A Hessian direction below this fraction of the total weight is degenerate")
      .number("degeneracy_length", &C::degeneracy_length, positive(),
              "m; a rotation θ weighs like a translation θ·length")
      .rule("coarse_source_points",
            [](const C& c) { return c.coarse_source_points == 0 || c.coarse_source_points >= c.min_correspondences; },
            "must be 0 (off) or >= min_correspondences");
  return f;
}

}  // namespace

const ConfigFields<RegistrationConfig>& configFields(ConfigTag<RegistrationConfig>) {
  static const ConfigFields<RegistrationConfig> fields = makeFields();
  return fields;
}

void RegistrationConfig::validate() const { validateConfig(*this, "registration"); }

double RegistrationConfig::effectiveMismatchPenalty(const ClassTable& classes) const {
  return use_classes ? classes.mismatch_penalty : 0.0;
}

RegistrationConfig registrationConfigFromYaml(const std::string& yaml, const std::string& where,
                                              const RegistrationConfig& base) {
  return configFromYaml(yaml, where, "registration", base);
}

RegistrationConfig loadRegistrationConfig(const std::string& path, const RegistrationConfig& base) {
  return registrationConfigFromYaml(readTextFile(path), path, base);
}

std::string toYamlString(const RegistrationConfig& c) { return configToYaml(c); }

}  // namespace hazmap
