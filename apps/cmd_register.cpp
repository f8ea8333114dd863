// hazmap register: align two clouds with (property-aware) ICP and print target ← source.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/transform_file.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap::cli {
namespace {

struct RegisterOptions {
  std::string source, target, init, method = "property-icp", metric = "plane", classes = "default";
  std::string config;
  double voxel = 0.0;
  double max_distance = 0.0;
  int max_iterations = 0;
  int threads = 0;
  bool json = false;
  bool global = false;
};

void printMatrix(const Eigen::Matrix4d& M) {
  for (int i = 0; i < 4; ++i) {
    char line[160];
    std::snprintf(line, sizeof line, "%.9g %.9g %.9g %.9g", M(i, 0), M(i, 1), M(i, 2), M(i, 3));
    std::cout << line << "\n";
  }
}

// --method: plain ICP or property-aware ICP.
bool usesClasses(const std::string& method) {
  if (method == "icp") return false;
  if (method == "property-icp") return true;
  fail("--method", "expected icp or property-icp, got '" + method + "'");
}

struct Inputs {
  ClassTable table;
  LabeledCloud source, target;
};

// The class table (with --set's property-ICP overrides) and both clouds, whose labels must be in
// the table when the registration uses them.
Inputs readInputs(const RegisterOptions& o, const ParameterOptions& params, bool use_classes) {
  Inputs in{params.propertyIcp().applyTo(ClassTable::load(o.classes)), {}, {}};
  in.source = readCloud(o.source, in.table);
  in.target = readCloud(o.target, in.table);
  if (use_classes) {
    in.table.checkCloud(in.source, o.source);
    in.table.checkCloud(in.target, o.target);
  }
  return in;
}

std::vector<double> rowMajor(const Eigen::Matrix4d& M) {
  std::vector<double> t;
  for (int i = 0; i < 4; ++i)
    for (int k = 0; k < 4; ++k) t.push_back(M(i, k));
  return t;
}

// --global: no initial guess; features, RANSAC and constellations, verified by property ICP.
void runGlobal(const RegisterOptions& o, const ParameterOptions& params) {
  if (!o.init.empty()) fail("--init", "a global registration takes no initial guess (drop --init or --global)");
  if (o.metric != "plane" || o.max_distance != 0.0 || o.max_iterations != 0)
    fail("--global", "--metric/--max-distance/--max-iterations set the local ICP; with --global use --set refinement.KEY=VALUE");
  GlobalRegistrationConfig cfg;
  if (!o.config.empty()) cfg = loadGlobalRegistrationConfig(o.config);
  cfg.use_classes = usesClasses(o.method);
  if (o.voxel < 0.0 || !std::isfinite(o.voxel)) fail("--voxel", "must be >= 0 (0 = the config's voxel_size)");
  if (o.voxel > 0.0) cfg.voxel_size = o.voxel;
  if (o.threads != 0) cfg.threads = o.threads;
  params.applySettings(cfg);
  cfg.validate();
  const Inputs in = readInputs(o, params, cfg.use_classes);
  const GlobalRegistrationResult r = registerGlobally(in.source, in.target, in.table, cfg);
  if (o.json) {
    nlohmann::json j;
    j["transform"] = rowMajor(r.transform.matrix());
    j["success"] = r.success;
    j["status"] = toString(r.status);
    if (!r.success) j["reason"] = r.reason;
    j["score"] = r.score;
    j["second_best_score"] = r.second_best_score;
    j["ambiguous"] = r.ambiguous;
    j["overlap"] = r.overlap;
    j["inliers"] = r.inliers;
    j["correspondences"] = r.correspondences;
    j["source_points"] = r.source_points;
    j["source_features"] = r.source_features;
    j["from_constellation"] = r.from_constellation;
    j["method"] = o.method;
    j["timings_ms"] = {{"features", r.timings.prepare_ms}, {"match", r.timings.match_ms},
                       {"hypotheses", r.timings.hypotheses_ms}, {"refine", r.timings.refine_ms},
                       {"total", r.timings.total_ms}};
    std::cout << j.dump(2) << "\n";
  } else {
    printMatrix(r.transform.matrix());
    std::fprintf(stderr, "%s%s%s: score %.3f (second %.3f), overlap %.2f, %zu/%zu matches agree, %.1f ms\n",
                 r.success ? "accepted" : "NOT accepted", r.success ? "" : " — ", r.reason.c_str(), r.score,
                 r.second_best_score, r.overlap, r.inliers, r.correspondences, r.timings.total_ms);
  }
  if (!r.success) exitCode() = 2;
}

void run(const RegisterOptions& o, const ParameterOptions& params) {
  if (o.global) return runGlobal(o, params);
  RegistrationConfig cfg;
  if (!o.config.empty()) cfg = loadRegistrationConfig(o.config);
  cfg.use_classes = usesClasses(o.method);
  if (o.metric == "point") cfg.metric = IcpMetric::PointToPoint;
  else if (o.metric == "plane") cfg.metric = IcpMetric::PointToPlane;
  else fail("--metric", "expected point or plane, got '" + o.metric + "'");
  if (o.max_distance != 0.0) cfg.max_correspondence_distance = o.max_distance;
  if (o.max_iterations != 0) cfg.max_iterations = o.max_iterations;
  if (o.threads != 0) cfg.threads = o.threads;
  params.applySettings(cfg);
  cfg.validate();
  if (o.voxel < 0.0 || !std::isfinite(o.voxel)) fail("--voxel", "must be >= 0 (0 = no downsampling)");

  const Inputs in = readInputs(o, params, cfg.use_classes);
  const Eigen::Isometry3d init = o.init.empty() ? Eigen::Isometry3d::Identity() : readTransformFile(o.init);
  const VoxelDownsampleConfig vd = propertyVoxels(o.voxel);
  const RegistrationResult r = o.voxel > 0.0 ? registerScans(in.source, in.target, init, in.table, vd, cfg)
                                             : registerClouds(in.source, in.target, init, in.table, cfg);

  if (o.json) {
    nlohmann::json j;
    std::vector<double> c;
    for (int i = 0; i < 6; ++i)
      for (int k = 0; k < 6; ++k) c.push_back(r.covariance(i, k));
    j["transform"] = rowMajor(r.transform.matrix());
    j["covariance"] = c;
    j["fitness"] = r.fitness;
    j["rmse"] = r.inlier_rmse;
    j["iterations"] = r.iterations;
    j["coarse_iterations"] = r.coarse_iterations;
    j["converged"] = r.converged;
    if (!r.converged) j["reason"] = r.reason;
    std::vector<std::vector<double>> dirs;
    for (const auto& d : r.degenerate_directions) dirs.push_back({d(0), d(1), d(2), d(3), d(4), d(5)});
    j["degenerate_directions"] = dirs;
    j["method"] = o.method;
    j["metric"] = o.metric;
    j["source_points"] = r.stats.source_points;
    j["matched"] = r.stats.matched;
    j["cross_class_matches"] = r.stats.cross_class;
    j["property_points"] = r.stats.property_points;
    j["property_matched_same_class"] = r.stats.property_matched;
    std::cout << j.dump(2) << "\n";
  } else {
    printMatrix(r.transform.matrix());
    std::fprintf(stderr, "%s, %d iterations, fitness %.3f, rmse %.4f m%s%s\n",
                 r.converged ? "converged" : "NOT converged", r.iterations, r.fitness, r.inlier_rmse,
                 r.converged ? "" : ": ", r.reason.c_str());
  }
  if (!r.converged) exitCode() = 2;
}

const RegisterCommand kRegister{{
    "register",
    "Align SOURCE to TARGET with property-aware ICP (or --global, without an initial guess); prints "
    "the 4x4 row-major target <- source transform (exit 2 if it did not converge / was not accepted)",
    [](CLI::App& app) {
      auto o = std::make_shared<RegisterOptions>();
      app.add_option("source", o->source, "Source cloud (.pcd, .ply, .bin [+ .label])")->required();
      app.add_option("target", o->target, "Target cloud")->required();
      app.add_option("--init", o->init, "Initial guess: file with a 4x4 row-major target <- source");
      app.add_option("--method", o->method, "icp | property-icp (the paper's eq. 2)");
      app.add_option("--metric", o->metric, "point | plane");
      app.add_option("--classes", o->classes, "Class table: default, semantic-kitti or a YAML file");
      app.add_option("--config", o->config, "Registration settings (YAML, see docs/registration.md)");
      app.add_option("--voxel", o->voxel, "Voxel-downsample both clouds first (m, 0 = off)");
      app.add_option("--max-distance", o->max_distance, "Max correspondence distance (m; 0 = config)");
      app.add_option("--max-iterations", o->max_iterations, "Iteration limit (0 = config)");
      app.add_option("--threads", o->threads, "Worker threads (0 = all)");
      app.add_flag("--json", o->json, "Print JSON: transform, covariance, fitness, rmse, iterations, converged");
      app.add_flag("--global", o->global,
                   "Global registration, no initial guess: FPFH + RANSAC + property-landmark constellations, "
                   "verified by property ICP (--config/--set then address the global_registration section; "
                   "exit 2 if not accepted, e.g. ambiguous)");
      auto params = addParameterOptions(app, "keys of the registration section, e.g. max_iterations=30");
      app.callback([o, params] { run(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
