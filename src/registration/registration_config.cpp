// RegistrationConfig: validation and YAML loading.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "hazmap/core/error.hpp"
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

void require(bool ok, const std::string& param, const std::string& what) {
  if (!ok) fail("registration config", param + " " + what);
}

bool finitePositive(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

void RegistrationConfig::validate() const {
  require(finitePositive(max_correspondence_distance), "max_correspondence_distance",
          "must be > 0 (got " + std::to_string(max_correspondence_distance) + ")");
  require(max_iterations >= 1, "max_iterations", "must be >= 1 (got " + std::to_string(max_iterations) + ")");
  require(std::isfinite(mismatch_penalty), "mismatch_penalty", "must be finite (< 0 = use the class table's)");
  require(label_confidence > 0.0 && label_confidence <= 1.0, "label_confidence", "must be in (0, 1]");
  require(std::isfinite(property_weight) && property_weight >= 0.0, "property_weight", "must be >= 0");
  require(property_tangent_weight >= 0.0 && property_tangent_weight <= 1.0, "property_tangent_weight",
          "must be in [0, 1]");
  require(std::isfinite(min_label_agreement) && min_label_agreement <= 1.0, "min_label_agreement",
          "must be finite and <= 1 (<= -1 = never ignore the labels)");
  require(finitePositive(robust_scale_factor), "robust_scale_factor", "must be > 0");
  require(finitePositive(robust_min_scale), "robust_min_scale", "must be > 0");
  require(std::isfinite(translation_tolerance) && translation_tolerance >= 0.0, "translation_tolerance", "must be >= 0");
  require(std::isfinite(rotation_tolerance) && rotation_tolerance >= 0.0, "rotation_tolerance", "must be >= 0");
  require(std::isfinite(correspondence_reuse_distance) && correspondence_reuse_distance >= 0.0,
          "correspondence_reuse_distance", "must be >= 0");
  require(min_correspondences >= 6, "min_correspondences", "must be >= 6 (six unknowns)");
  require(normal_neighbors >= 3, "normal_neighbors", "must be >= 3");
  require(finitePositive(normal_radius), "normal_radius", "must be > 0");
  require(std::isfinite(index_cell_size) && index_cell_size >= 0.0, "index_cell_size", "must be >= 0 (0 = automatic)");
  require(threads >= 0, "threads", "must be >= 0 (0 = automatic)");
  require(coarse_source_points == 0 || coarse_source_points >= min_correspondences, "coarse_source_points",
          "must be 0 (off) or >= min_correspondences");
  require(std::isfinite(degeneracy_threshold) && degeneracy_threshold >= 0.0 && degeneracy_threshold < 1.0,
          "degeneracy_threshold", "must be in [0, 1)");
  require(finitePositive(degeneracy_length), "degeneracy_length", "must be > 0");
}

double RegistrationConfig::effectiveMismatchPenalty(const ClassTable& classes) const {
  if (!use_classes) return 0.0;
  return mismatch_penalty >= 0.0 ? mismatch_penalty : classes.mismatch_penalty;
}

RegistrationConfig registrationConfigFromYaml(const std::string& yaml, const std::string& where,
                                              const RegistrationConfig& base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  RegistrationConfig c = base;
  if (!root || root.IsNull()) return c;
  if (!root.IsMap()) fail(where, "registration config must be a YAML mapping");
  // A file may hold the settings at the top level or under `registration:`.
  if (root["registration"] && root["registration"].IsMap()) root = root["registration"];
  std::set<std::string> seen;
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    const YAML::Node& v = kv.second;
    seen.insert(key);
    const auto get = [&](auto& field) {
      try {
        field = v.as<std::remove_reference_t<decltype(field)>>();
      } catch (const YAML::Exception&) {
        fail(where, "bad value for '" + key + "'");
      }
    };
    const auto text = [&] {
      std::string s;
      get(s);
      return s;
    };
    if (key == "use_classes") get(c.use_classes);
    else if (key == "metric") {
      const std::string s = text();
      if (s == "point" || s == "point-to-point") c.metric = IcpMetric::PointToPoint;
      else if (s == "plane" || s == "point-to-plane") c.metric = IcpMetric::PointToPlane;
      else fail(where, "metric must be 'point' or 'plane' (got '" + s + "')");
    } else if (key == "max_correspondence_distance") get(c.max_correspondence_distance);
    else if (key == "max_iterations") get(c.max_iterations);
    else if (key == "mismatch_penalty") get(c.mismatch_penalty);
    else if (key == "label_mode") {
      const std::string s = text();
      if (s == "hard") c.label_mode = LabelMode::Hard;
      else if (s == "soft") c.label_mode = LabelMode::Soft;
      else fail(where, "label_mode must be 'hard' or 'soft' (got '" + s + "')");
    } else if (key == "label_confidence") get(c.label_confidence);
    else if (key == "use_class_weights") get(c.use_class_weights);
    else if (key == "property_weight") get(c.property_weight);
    else if (key == "property_point_to_point") get(c.property_point_to_point);
    else if (key == "property_tangent_weight") get(c.property_tangent_weight);
    else if (key == "min_label_agreement") get(c.min_label_agreement);
    else if (key == "min_label_pairs") get(c.min_label_pairs);
    else if (key == "robust_kernel") {
      const std::string s = text();
      if (s == "none") c.robust_kernel = RobustKernel::None;
      else if (s == "huber") c.robust_kernel = RobustKernel::Huber;
      else if (s == "geman-mcclure" || s == "gm") c.robust_kernel = RobustKernel::GemanMcClure;
      else fail(where, "robust_kernel must be none, huber or geman-mcclure (got '" + s + "')");
    } else if (key == "robust_scale_factor") get(c.robust_scale_factor);
    else if (key == "robust_min_scale") get(c.robust_min_scale);
    else if (key == "translation_tolerance") get(c.translation_tolerance);
    else if (key == "rotation_tolerance") get(c.rotation_tolerance);
    else if (key == "correspondence_reuse_distance") get(c.correspondence_reuse_distance);
    else if (key == "min_correspondences") get(c.min_correspondences);
    else if (key == "normal_neighbors") get(c.normal_neighbors);
    else if (key == "normal_radius") get(c.normal_radius);
    else if (key == "index") {
      const std::string s = text();
      if (s == "voxel" || s == "voxel-hash") c.index = SpatialIndexKind::VoxelHash;
      else if (s == "kdtree" || s == "k-d tree") c.index = SpatialIndexKind::KdTree;
      else fail(where, "index must be 'voxel' or 'kdtree' (got '" + s + "')");
    } else if (key == "index_cell_size") get(c.index_cell_size);
    else if (key == "max_source_points") get(c.max_source_points);
    else if (key == "coarse_source_points") get(c.coarse_source_points);
    else if (key == "threads") get(c.threads);
    else if (key == "degeneracy_threshold") get(c.degeneracy_threshold);
    else if (key == "degeneracy_length") get(c.degeneracy_length);
    else fail(where, "unknown registration setting '" + key + "'");
  }
  try {
    c.validate();
  } catch (const Error& e) {
    fail(where, e.what());
  }
  return c;
}

RegistrationConfig loadRegistrationConfig(const std::string& path, const RegistrationConfig& base) {
  std::ifstream in(path);
  if (!in) fail(path, "cannot open registration config");
  std::stringstream ss;
  ss << in.rdbuf();
  return registrationConfigFromYaml(ss.str(), path, base);
}

std::string toYamlString(const RegistrationConfig& c) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "use_classes" << YAML::Value << c.use_classes;
  out << YAML::Key << "metric" << YAML::Value << toString(c.metric);
  out << YAML::Key << "max_correspondence_distance" << YAML::Value << c.max_correspondence_distance;
  out << YAML::Key << "max_iterations" << YAML::Value << c.max_iterations;
  out << YAML::Key << "mismatch_penalty" << YAML::Value << c.mismatch_penalty;
  out << YAML::Key << "label_mode" << YAML::Value << toString(c.label_mode);
  out << YAML::Key << "label_confidence" << YAML::Value << c.label_confidence;
  out << YAML::Key << "use_class_weights" << YAML::Value << c.use_class_weights;
  out << YAML::Key << "property_weight" << YAML::Value << c.property_weight;
  out << YAML::Key << "property_point_to_point" << YAML::Value << c.property_point_to_point;
  out << YAML::Key << "property_tangent_weight" << YAML::Value << c.property_tangent_weight;
  out << YAML::Key << "min_label_agreement" << YAML::Value << c.min_label_agreement;
  out << YAML::Key << "min_label_pairs" << YAML::Value << c.min_label_pairs;
  out << YAML::Key << "robust_kernel" << YAML::Value << toString(c.robust_kernel);
  out << YAML::Key << "robust_scale_factor" << YAML::Value << c.robust_scale_factor;
  out << YAML::Key << "robust_min_scale" << YAML::Value << c.robust_min_scale;
  out << YAML::Key << "translation_tolerance" << YAML::Value << c.translation_tolerance;
  out << YAML::Key << "rotation_tolerance" << YAML::Value << c.rotation_tolerance;
  out << YAML::Key << "correspondence_reuse_distance" << YAML::Value << c.correspondence_reuse_distance;
  out << YAML::Key << "min_correspondences" << YAML::Value << c.min_correspondences;
  out << YAML::Key << "normal_neighbors" << YAML::Value << c.normal_neighbors;
  out << YAML::Key << "normal_radius" << YAML::Value << c.normal_radius;
  out << YAML::Key << "index" << YAML::Value << toString(c.index);
  out << YAML::Key << "index_cell_size" << YAML::Value << c.index_cell_size;
  out << YAML::Key << "max_source_points" << YAML::Value << c.max_source_points;
  out << YAML::Key << "coarse_source_points" << YAML::Value << c.coarse_source_points;
  out << YAML::Key << "threads" << YAML::Value << c.threads;
  out << YAML::Key << "degeneracy_threshold" << YAML::Value << c.degeneracy_threshold;
  out << YAML::Key << "degeneracy_length" << YAML::Value << c.degeneracy_length;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace hazmap
