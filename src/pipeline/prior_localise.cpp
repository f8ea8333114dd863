// Localising a finished run in a prior map and joining their graphs (pipeline/prior_map.hpp).
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/pipeline/prior_map.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/global_registration.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/map_folder_output.hpp"
#include "pipeline/prior_search.hpp"

namespace hazmap {

using namespace pipeline_detail;

namespace {

// The prior keyframes are held by edges this stiff: the prior moves only by millimetres.
constexpr double kPriorSigmaTranslation = 0.001, kPriorSigmaRotation = 0.0001;

Matrix6d diagonalInformation(double sigma_t, double sigma_r) {
  Vector6d d;
  d << Eigen::Vector3d::Constant(1.0 / (sigma_t * sigma_t)), Eigen::Vector3d::Constant(1.0 / (sigma_r * sigma_r));
  return d.asDiagonal();
}

// Every pose of the run moved into the prior's frame.
void moveRun(SlamResult& result, const Eigen::Isometry3d& T) {
  for (auto* t : {&result.estimate, &result.tracked, &result.odometry_only})
    for (auto& p : t->poses) p = normalized(T * p);
  for (auto& p : result.graph.poses) p = normalized(T * p);
}

// The run's graph with the prior's keyframes (held by stiff edges, the first fixed) and the loops
// to them, solved in the prior's frame; the run's poses taken back.
void solveJointly(const PriorIndex& prior, const std::vector<PriorEdge>& edges, SlamResult& result,
                  const SlamConfig& config, PriorLocalisation& out) {
  PoseGraph g = result.graph;
  const int base = g.numNodes();
  for (std::size_t i = 0; i < prior.size(); ++i) {
    g.addNode(prior.pose(i));
    if (i > 0)
      g.addEdge(base + static_cast<int>(i) - 1, base + static_cast<int>(i), prior.pose(i - 1).inverse() * prior.pose(i),
                diagonalInformation(kPriorSigmaTranslation, kPriorSigmaRotation), EdgeKind::Odometry);
  }
  g.fixed_node = base;
  for (const auto& e : edges)
    g.addEdge(base + static_cast<int>(e.prior_keyframe), static_cast<int>(e.frame), e.T_prior_frame, e.information,
              EdgeKind::Loop);
  std::string failure;
  optimizePoseGraphOrKeep(g, config.graph, failure);
  if (!failure.empty()) return void(out.optimisation_note = failure);
  out.optimised = true;
  for (int i = 0; i < base; ++i) result.graph.poses[static_cast<std::size_t>(i)] = g.poses[static_cast<std::size_t>(i)];
  result.estimate.poses.assign(result.graph.poses.begin(), result.graph.poses.end());
}

}  // namespace

PriorLocalisation localiseInPrior(const MapFolder& prior_map, ScanSource& scans, SlamResult& result,
                                  const SlamConfig& config) {
  const auto t0 = Clock::now();
  PriorLocalisation out;
  const ClassTable classes = config.property_icp.applyTo(scans.classTable(), scans.describe());
  const RunKeyframes run = readRunKeyframes(scans, result, config, classes);
  const auto t_prepare = Clock::now();
  const PriorIndex prior(prior_map, classes, config);
  out.prepare_seconds = secondsSince(t_prepare);
  out.stored_overview = prior.usedStoredOverview();
  out.prior_keyframes = prior.size();
  const double height = run.sensorHeight(), prior_height = prior_map.manifest().sensor_height;
  if (std::isfinite(height) && std::isfinite(prior_height) && std::abs(height - prior_height) > kSensorHeightTolerance)
    out.warnings.push_back(fmt::format("the sensor is {:.2f} m above the floor, {:.2f} m in the prior map", height,
                                       prior_height));
  searchPrior(prior, run, result.estimate.poses, classes, config, out);
  out.search_seconds = secondsSince(t0);
  if (out.state != PriorState::Localised) {
    out.state = PriorState::NeverLocalised;
    out.prior_keyframes_read = prior.keyframesRead();
    out.total_seconds = secondsSince(t0);
    return out;
  }
  FramePoses moved = result.estimate.poses;
  for (auto& p : moved) p = normalized(out.T_prior_run * p);
  const std::vector<PriorEdge> edges = loopsToPrior(prior, run, moved, classes, config, out);
  // As a merge: two agreeing answers are not enough, most keyframes must verify where they land.
  if (placementConfirmed(edges, "the prior", out)) {
    moveRun(result, out.T_prior_run);
    solveJointly(prior, edges, result, config, out);
  }
  out.prior_keyframes_read = prior.keyframesRead();
  out.total_seconds = secondsSince(t0);
  return out;
}

}  // namespace hazmap
