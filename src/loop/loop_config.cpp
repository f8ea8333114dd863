// LoopClosureConfig: validation and YAML round trip.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "hazmap/core/error.hpp"
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

void LoopClosureConfig::validate() const {
  hazmap::validate(landmarks);
  hazmap::validate(candidates);
  hazmap::validate(verification);
  hazmap::validate(consistency);
  if (max_loops_per_keyframe < 1) fail("loop_closure", "max_loops_per_keyframe must be >= 1");
  if (landmark_window < 1) fail("loop_closure", "landmark_window must be >= 1");
  if (!(landmark_merge_distance > 0.0) || !std::isfinite(landmark_merge_distance))
    fail("loop_closure", "landmark_merge_distance must be a finite number > 0");
  if (resident_keyframes < 1) fail("loop_closure", "resident_keyframes must be >= 1");
  if (!(keyframe_voxel >= 0.0) || !std::isfinite(keyframe_voxel))
    fail("loop_closure", "keyframe_voxel must be >= 0 (0 = no downsampling)");
}

namespace {

// One YAML mapping: typed reads that remember the keys seen, then a check for unknown keys.
class Section {
 public:
  Section(YAML::Node node, std::string where) : node_(std::move(node)), where_(std::move(where)) {
    if (node_ && !node_.IsNull() && !node_.IsMap()) fail(where_, "must be a mapping");
  }
  template <typename T>
  void get(const char* key, T& value) {
    known_.insert(key);
    if (!node_ || !node_.IsMap() || !node_[key]) return;
    try {
      value = node_[key].as<T>();
    } catch (const YAML::Exception&) {
      fail(where_, std::string("bad value for '") + key + "'");
    }
  }
  void getSize(const char* key, std::size_t& value) {
    long long v = static_cast<long long>(value);
    get(key, v);
    if (v < 0) fail(where_, std::string("'") + key + "' must be >= 0");
    value = static_cast<std::size_t>(v);
  }
  template <typename E>
  void getEnum(const char* key, E& value, std::initializer_list<std::pair<const char*, E>> names) {
    std::string text;
    get(key, text);
    if (text.empty()) return;
    for (const auto& [n, e] : names)
      if (text == n) {
        value = e;
        return;
      }
    std::string options;
    for (const auto& [n, e] : names) options += (options.empty() ? "" : ", ") + std::string(n);
    fail(where_, std::string("'") + key + "' must be one of " + options + " (got '" + text + "')");
  }
  YAML::Node raw(const char* key) {
    known_.insert(key);
    return node_ && node_.IsMap() ? node_[key] : YAML::Node();
  }
  Section child(const char* key) {
    known_.insert(key);
    return Section(node_ && node_.IsMap() ? node_[key] : YAML::Node(), where_ + "." + key);
  }
  void finish() const {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      const auto k = kv.first.as<std::string>();
      if (!known_.count(k)) fail(where_, "unknown key '" + k + "'");
    }
  }

 private:
  YAML::Node node_;
  std::string where_;
  std::set<std::string> known_;
};

}  // namespace

LoopClosureConfig LoopClosureConfig::fromYamlFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) fail(path.string(), "cannot open loop-closure config");
  std::stringstream ss;
  ss << in.rdbuf();
  return fromYamlString(ss.str(), path.string());
}

LoopClosureConfig LoopClosureConfig::fromYamlString(const std::string& yaml, const std::string& where) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
  }
  LoopClosureConfig c;
  if (!root || root.IsNull()) return c;
  if (!root.IsMap()) fail(where, "loop-closure config must be a YAML mapping");
  YAML::Node node = root["loop_closure"] ? root["loop_closure"] : root;
  const std::string prefix = where + ": loop_closure";
  try {
    Section top(node, prefix);
    top.getEnum("method", c.method, {{"constellation", CandidateMethod::Constellation},
                                     {"distance", CandidateMethod::Distance},
                                     {"both", CandidateMethod::Both}});
    top.getSize("max_loops_per_keyframe", c.max_loops_per_keyframe);
    top.get("keyframe_voxel", c.keyframe_voxel);
    top.getSize("resident_keyframes", c.resident_keyframes);
    top.getSize("landmark_window", c.landmark_window);
    top.get("landmark_merge_distance", c.landmark_merge_distance);

    Section lm = top.child("landmarks");
    lm.get("cluster_tolerance", c.landmarks.cluster_tolerance);
    lm.getSize("min_points", c.landmarks.min_points);
    lm.get("max_range", c.landmarks.max_range);
    lm.get("min_purity", c.landmarks.min_purity);
    lm.finish();

    Section cs = top.child("candidates");
    cs.getSize("min_index_gap", c.candidates.min_index_gap);
    cs.get("search_radius", c.candidates.search_radius);
    cs.getSize("max_candidates", c.candidates.max_candidates);
    Section co = cs.child("constellation");
    ConstellationConfig& k = c.candidates.constellation;
    co.getEnum("model", k.model, {{"planar", ConstellationModel::Planar},
                                  {"full-3d", ConstellationModel::Full3D}});
    co.get("distance_tolerance", k.distance_tolerance);
    co.get("inlier_distance", k.inlier_distance);
    co.getSize("min_inliers", k.min_inliers);
    co.get("min_pair_distance", k.min_pair_distance);
    co.get("min_triangle_height", k.min_triangle_height);
    co.get("max_extent_ratio", k.max_extent_ratio);
    co.get("property_value_tolerance", k.property_value_tolerance);
    co.getSize("max_hypotheses", k.max_hypotheses);
    co.get("seed", k.seed);
    co.get("visibility_range", k.visibility_range);
    co.get("miss_penalty", k.miss_penalty);
    co.get("min_overlap", k.min_overlap);
    co.get("facing_tolerance", k.facing_tolerance);
    co.finish();
    cs.finish();

    Section ve = top.child("verification");
    VerificationConfig& v = c.verification;
    ve.get("min_fitness", v.min_fitness);
    ve.get("max_rmse", v.max_rmse);
    ve.get("max_translation_sigma", v.max_translation_sigma);
    ve.get("max_rotation_sigma", v.max_rotation_sigma);
    ve.get("reject_degenerate", v.reject_degenerate);
    ve.get("max_correction_translation", v.max_correction_translation);
    ve.get("max_correction_rotation", v.max_correction_rotation);
    ve.get("min_translation_sigma", v.min_translation_sigma);
    ve.get("min_rotation_sigma", v.min_rotation_sigma);
    // The registration section is the registration stage's own config (its loader, its keys).
    if (const YAML::Node re = ve.raw("registration"); re && !re.IsNull())
      v.registration = registrationConfigFromYaml(YAML::Dump(re), where + ": loop_closure.verification.registration",
                                                  v.registration);
    ve.finish();

    Section cn = top.child("consistency");
    ConsistencyConfig& g = c.consistency;
    cn.get("translation_drift_per_metre", g.translation_drift_per_metre);
    cn.get("rotation_drift_per_metre", g.rotation_drift_per_metre);
    cn.get("translation_sigma_floor", g.translation_sigma_floor);
    cn.get("rotation_sigma_floor", g.rotation_sigma_floor);
    cn.get("gate_probability", g.gate_probability);
    cn.get("use_drift_gate", g.use_drift_gate);
    cn.get("use_pairwise", g.use_pairwise);
    cn.finish();
    top.finish();
    c.validate();
  } catch (const Error& e) {
    const std::string msg = e.what();
    // Validation errors name the parameter but not the file.
    if (msg.rfind(where, 0) == 0) throw;
    fail(where, msg);
  }
  return c;
}

std::string LoopClosureConfig::toYamlString() const {
  YAML::Emitter o;
  o.SetDoublePrecision(10);
  o << YAML::BeginMap << YAML::Key << "loop_closure" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "method" << YAML::Value << toString(method);
  o << YAML::Key << "max_loops_per_keyframe" << YAML::Value << max_loops_per_keyframe;
  o << YAML::Key << "keyframe_voxel" << YAML::Value << keyframe_voxel;
  o << YAML::Key << "resident_keyframes" << YAML::Value << resident_keyframes;
  o << YAML::Key << "landmark_window" << YAML::Value << landmark_window;
  o << YAML::Key << "landmark_merge_distance" << YAML::Value << landmark_merge_distance;
  o << YAML::Key << "landmarks" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "cluster_tolerance" << YAML::Value << landmarks.cluster_tolerance;
  o << YAML::Key << "min_points" << YAML::Value << landmarks.min_points;
  o << YAML::Key << "max_range" << YAML::Value << landmarks.max_range;
  o << YAML::Key << "min_purity" << YAML::Value << landmarks.min_purity << YAML::EndMap;
  const ConstellationConfig& k = candidates.constellation;
  o << YAML::Key << "candidates" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "min_index_gap" << YAML::Value << candidates.min_index_gap;
  o << YAML::Key << "search_radius" << YAML::Value << candidates.search_radius;
  o << YAML::Key << "max_candidates" << YAML::Value << candidates.max_candidates;
  o << YAML::Key << "constellation" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "model" << YAML::Value << (k.model == ConstellationModel::Planar ? "planar" : "full-3d");
  o << YAML::Key << "distance_tolerance" << YAML::Value << k.distance_tolerance;
  o << YAML::Key << "inlier_distance" << YAML::Value << k.inlier_distance;
  o << YAML::Key << "min_inliers" << YAML::Value << k.min_inliers;
  o << YAML::Key << "min_pair_distance" << YAML::Value << k.min_pair_distance;
  o << YAML::Key << "min_triangle_height" << YAML::Value << k.min_triangle_height;
  o << YAML::Key << "max_extent_ratio" << YAML::Value << k.max_extent_ratio;
  o << YAML::Key << "property_value_tolerance" << YAML::Value << k.property_value_tolerance;
  o << YAML::Key << "max_hypotheses" << YAML::Value << k.max_hypotheses;
  o << YAML::Key << "seed" << YAML::Value << k.seed;
  o << YAML::Key << "visibility_range" << YAML::Value << k.visibility_range;
  o << YAML::Key << "miss_penalty" << YAML::Value << k.miss_penalty;
  o << YAML::Key << "min_overlap" << YAML::Value << k.min_overlap;
  o << YAML::Key << "facing_tolerance" << YAML::Value << k.facing_tolerance;
  o << YAML::EndMap << YAML::EndMap;
  const VerificationConfig& v = verification;
  o << YAML::Key << "verification" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "min_fitness" << YAML::Value << v.min_fitness;
  o << YAML::Key << "max_rmse" << YAML::Value << v.max_rmse;
  o << YAML::Key << "max_translation_sigma" << YAML::Value << v.max_translation_sigma;
  o << YAML::Key << "max_rotation_sigma" << YAML::Value << v.max_rotation_sigma;
  o << YAML::Key << "reject_degenerate" << YAML::Value << v.reject_degenerate;
  o << YAML::Key << "max_correction_translation" << YAML::Value << v.max_correction_translation;
  o << YAML::Key << "max_correction_rotation" << YAML::Value << v.max_correction_rotation;
  o << YAML::Key << "min_translation_sigma" << YAML::Value << v.min_translation_sigma;
  o << YAML::Key << "min_rotation_sigma" << YAML::Value << v.min_rotation_sigma;
  o << YAML::Key << "registration" << YAML::Value << YAML::Load(hazmap::toYamlString(v.registration));
  o << YAML::EndMap;
  const ConsistencyConfig& g = consistency;
  o << YAML::Key << "consistency" << YAML::Value << YAML::BeginMap;
  o << YAML::Key << "translation_drift_per_metre" << YAML::Value << g.translation_drift_per_metre;
  o << YAML::Key << "rotation_drift_per_metre" << YAML::Value << g.rotation_drift_per_metre;
  o << YAML::Key << "translation_sigma_floor" << YAML::Value << g.translation_sigma_floor;
  o << YAML::Key << "rotation_sigma_floor" << YAML::Value << g.rotation_sigma_floor;
  o << YAML::Key << "gate_probability" << YAML::Value << g.gate_probability;
  o << YAML::Key << "use_drift_gate" << YAML::Value << g.use_drift_gate;
  o << YAML::Key << "use_pairwise" << YAML::Value << g.use_pairwise;
  o << YAML::EndMap << YAML::EndMap << YAML::EndMap;
  return std::string(o.c_str()) + "\n";
}

}  // namespace hazmap
