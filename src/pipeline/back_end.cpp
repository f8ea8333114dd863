#include "pipeline/back_end.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "hazmap/graph/chain_covariance.hpp"
#include "hazmap/graph/keyframe_graph.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/loop_edges.hpp"

namespace hazmap::pipeline_detail {

BackEnd::BackEnd(const SlamConfig& config, SlamResult& result, const FrameRecordStore& records,
                 const TrackedPoses& tracked)
    : config_(config), result_(result), records_(records), tracked_(tracked),
      schedule_(config.loop_search_every, config.loop_pause_after_accept), anchors_(config) {}

void BackEnd::start(const ClassTable& classes, ScanSource& source, std::mutex* source_lock) {
  loops_ = std::make_unique<LoopDetector>(classes, loopClosureConfigFor(config_));
  if (config_.innovation_gate)
    loops_->setRelativeCovariance([this](std::size_t from, std::size_t to) { return relativeCovariance(from, to); });
  // Old keyframes are re-read when a loop needs them (bounded memory): from the recording when
  // it allows that, else from the copies a stream's keyframes leave on disk.
  if (source.canReread()) {
    loops_->setCloudLoader([this, &source, source_lock](std::size_t k) {
      const std::size_t f = keyframe_frames_.at(k);
      std::unique_lock<std::mutex> lock;
      if (source_lock) lock = std::unique_lock<std::mutex>(*source_lock);
      LabeledCloud cloud = source.reread(f);
      if (lock) lock.unlock();
      redoDeskew(cloud, records_.read(f));
      return cloud;
    });
  } else {
    spill_.emplace();
    loops_->setCloudLoader([this, &source](std::size_t k) { return spill_->load(keyframe_frames_.at(k), source.classTable()); });
  }
}

void BackEnd::journalOlderThan(std::size_t keep) {
  step_covariance_.keepNewest(keep);
  journal_keep_ = std::max<std::size_t>(keep, 1);
}

// At least this many edges (~14 kB) at a time, at a keyframe: the list in memory stays short, and so
// does each keyframe's scan for what may go.
constexpr std::size_t kEdgeJournalBatch = 32;

void BackEnd::journalOldEdges() {
  if (journal_keep_ == 0 || records_.size() <= journal_keep_) return;
  edges_.journalBefore(result_.graph, records_.size() - journal_keep_, kEdgeJournalBatch);
}

void BackEnd::addStep(const FrameRecord& rec, const Matrix6d& edge_covariance) {
  step_covariance_.push_back(edge_covariance);
  anchors_.addStep(rec, edge_covariance);
}

// Frame-to-map tracking: the gravity priors' σ × this (issue 37: a constant, not a key). Scans
// registered against the same map have anticorrelated increment errors (naraha: tracking's tilt
// stays within ~0.05° over 160 frames), but the graph chains them as independent (0.5 mrad per
// step, a random walk), so honest priors would outweigh the chain over a few metres and add their
// own noise (docs/pose_graph.md, 2026-12-02 gravity section: σ × 1 makes naraha 2 and 7 worse, × 3 never).
constexpr double kGravitySigmaScaleFrameToMap = 3.0;

// Roll and pitch observed absolutely (PoseGraphConfig::gravity_prior), also where no loop reaches.
void BackEnd::addGravityPrior(const std::optional<GravitySample>& gravity) {
  if (!config_.graph.gravity_prior || !gravity) return;
  double sigma = config_.graph.gravity_sigma_deg > 0.0 ? config_.graph.gravity_sigma_deg * M_PI / 180.0
                                                      : gravity->sigmaRad();
  if (config_.odometry.mode == OdometryMode::FrameToMap) sigma *= kGravitySigmaScaleFrameToMap;
  result_.graph.addGravityPrior(static_cast<int>(records_.size() - 1), gravity->down, sigma);
}

void BackEnd::closeLoops(LabeledCloud cloud) {
  const auto t_loop = Clock::now();
  journalOldEdges();
  keyframe_frames_.push_back(records_.size() - 1);
  if (spill_) spill_->store(keyframe_frames_.back(), cloud);
  const std::size_t k = loops_->addKeyframe(std::move(cloud));
  if (const auto anchor = anchors_.anchorNewest(keyframe_frames_, tracked_, records_.back(), result_.graph))
    result_.anchors.push_back(*anchor);
  if (!schedule_.searches(k)) return void(result_.timings.loop_s += secondsSince(t_loop));
  ++result_.keyframes_searched;
  const LoopDetection detection = loops_->detect(k, keyframeEstimate());
  if (!detection.accepted.empty()) schedule_.accepted(k);
  recordDetection(detection);
  result_.timings.loop_s += secondsSince(t_loop);
  loops_pending_ = loops_pending_ || !detection.accepted.empty();
  if (loops_pending_ && config_.optimise_online && solveDue(k)) optimiseWithLoops();
}

bool BackEnd::solveDue(std::size_t keyframe) const {
  return keyframe >= last_solve_keyframe_ + keyframesBetweenSolves(result_.graph.poses.size());
}

void BackEnd::recordDetection(const LoopDetection& detection) {
  result_.loop_candidates += detection.candidates.size();
  result_.loop_light_verifications += detection.light_verifications;
  result_.submap_targets_built = loops_->submapTargetsBuilt();
  for (const auto& v : detection.verifications) {
    result_.loops_verified += v.accepted ? 1 : 0;
    if (!v.accepted) reject(v.closure, v.rejection, v.reason);
  }
}

void BackEnd::finish() {
  finishing_ = true;
  edges_.restore(result_.graph);  // the run's graph whole from here on
  journal_keep_ = 0;
  result_.keyframes = keyframe_frames_.size();
  optimiseWithLoops();
  anchors_.refreshInformation(result_.graph);  // the graph written out carries what the last solve used
  const auto consistent = loops_->consistentLoops(keyframeEstimate());
  setLoopEdges(result_.graph, consistent, keyframe_frames_);
  if (consistent.empty() && gravityAloneHelps()) optimise();
  recordLoops(consistent);
}

void BackEnd::describeLoopsSoFar(SlamResult& snapshot) const {
  snapshot.keyframes = keyframe_frames_.size();
  std::set<std::pair<int, int>> in_graph;
  for (const PoseGraphEdge& e : snapshot.graph.edges)
    if (e.kind == EdgeKind::Loop) in_graph.insert({e.from, e.to});
  snapshot.loops.clear();
  for (const auto& l : loops_->acceptedLoops()) {
    const std::size_t from = keyframe_frames_[l.from], to = keyframe_frames_[l.to];
    if (in_graph.count({static_cast<int>(from), static_cast<int>(to)})) snapshot.loops.push_back(recordOf(l));
  }
}

LoopRecord BackEnd::recordOf(const LoopClosure& l) const {
  return {keyframe_frames_[l.from], keyframe_frames_[l.to], toString(l.source), l.fitness, l.rmse};
}

void BackEnd::recordLoops(const std::vector<LoopClosure>& consistent) {
  for (const auto& l : loops_->acceptedLoops()) {
    const bool kept = std::any_of(consistent.begin(), consistent.end(),
                                  [&](const LoopClosure& c) { return c.from == l.from && c.to == l.to; });
    if (kept)
      result_.loops.push_back(recordOf(l));
    else
      reject(l, LoopRejection::Inconsistent, "not in the largest pairwise-consistent set");
  }
}

// Using the map anchor's covariance instead when one links the two keyframes was measured worse
// (corridor seed 1 0.129 → 0.142 m, docs/pose_graph.md).
Matrix6d BackEnd::relativeCovariance(std::size_t from, std::size_t to) const {
  JournaledList<Matrix6d>::Cursor step(step_covariance_);
  return chainCovariance(result_.graph.poses, keyframe_frames_.at(from), keyframe_frames_.at(to),
                         [&](std::size_t k) { return &step(k); });
}

void BackEnd::reject(const LoopClosure& l, LoopRejection why, std::string detail) {
  result_.rejected_loops.push_back({keyframe_frames_.at(l.from), keyframe_frames_.at(l.to), why, std::move(detail)});
}

void BackEnd::dropLoop(const LoopClosure& l, LoopRejection why, const std::string& detail) {
  loops_->dropLoop(l.from, l.to);
  reject(l, why, detail);
}

// On the whole graph: its loop edges are replaced, its anchors refreshed, all of it solved.
void BackEnd::optimiseWithLoops() {
  loops_pending_ = false;
  if (!keyframe_frames_.empty()) last_solve_keyframe_ = keyframe_frames_.size() - 1;
  edges_.restore(result_.graph);
  solveWithConsistentLoops();
  journalOldEdges();
}

// The pairwise-consistent loops into the graph and one optimisation; a loop the solution cannot
// agree with (its whitened residual beyond the gate's χ² quantile) or a failed solve is dropped,
// recorded, and the previous estimate kept (then re-solved without the loop).
void BackEnd::solveWithConsistentLoops() {
  for (int attempt = 0; attempt < 3; ++attempt) {
    const std::vector<LoopClosure> consistent = loops_->consistentLoops(keyframeEstimate());
    if (consistent.empty()) return;
    setLoopEdges(result_.graph, consistent, keyframe_frames_);
    const std::vector<Eigen::Isometry3d> before = result_.graph.poses;
    const std::string failure = optimise();
    if (failure.empty()) {
      const std::vector<LoopClosure> misfits = loopsTheSolutionRejects(
          result_.graph, consistent, keyframe_frames_, config_.loop_closure.consistency.gate_probability);
      if (misfits.empty()) return;
      result_.optimisation_outcomes.back() = {false, "dropped " + std::to_string(misfits.size()) +
                                                        " loop(s) the solution could not agree with"};
      for (const auto& l : misfits) dropLoop(l, LoopRejection::OptimisationDiverged, "residual beyond the χ² gate after optimisation");
    } else {
      for (const auto& l : consistent)
        if (l.to == consistent.back().to) dropLoop(l, LoopRejection::OptimisationFailed, failure);
    }
    result_.graph.poses = before;
  }
}

// On failure (Ceres cannot solve it, non-finite or higher cost) the poses are restored and the
// reason returned.
std::string BackEnd::optimise() {
  anchors_.refreshInformation(result_.graph);
  const auto t = Clock::now();
  std::string failure;
  result_.optimisations.push_back(solvesKeyframes() ? optimiseKeyframes(failure)
                                                    : optimizePoseGraphOrKeep(result_.graph, config_.graph, failure));
  result_.optimisation_outcomes.push_back({failure.empty(), failure.empty() ? "" : "not solved, previous estimate kept: " + failure});
  result_.timings.graph_s += secondsSince(t);
  return failure;
}

bool BackEnd::solvesKeyframes() const {
  const std::size_t after = config_.online_keyframe_graph_after;
  return !finishing_ && after > 0 && result_.graph.poses.size() > after;
}

// The keyframes' graph solved (graph/keyframe_graph.hpp), the frames between moved with theirs;
// the whole graph where it is not a keyframe chain.
PoseGraphReport BackEnd::optimiseKeyframes(std::string& failure) {
  const std::vector<int> kept(keyframe_frames_.begin(), keyframe_frames_.end());
  std::optional<PoseGraph> keyframes = keyframeGraph(result_.graph, kept);
  if (!keyframes) return optimizePoseGraphOrKeep(result_.graph, config_.graph, failure);
  const PoseGraphReport report = optimizePoseGraphOrKeep(*keyframes, config_.graph, failure);
  if (failure.empty()) applyKeyframeSolution(result_.graph, kept, *keyframes);
  return report;
}

// A run that closed no loop is optimised with its gravity priors alone only frame to frame. Frame
// to map the graph then holds nothing but tracking's own increments and priors noisier than
// tracking's attitude (~0.05° against one 0.2° reading), so the solve would only add their noise
// (corridor 4 icp+pgo: tilt error 0.046° → 0.052°, map 0.4955 → 0.5013 m; docs/pose_graph.md).
bool BackEnd::gravityAloneHelps() const {
  if (result_.graph.gravity_priors.empty()) return false;
  return config_.odometry.mode != OdometryMode::FrameToMap;
}

PoseList BackEnd::keyframeEstimate() const {
  PoseList poses;
  for (std::size_t f : keyframe_frames_) poses.push_back(result_.graph.poses[f]);
  return poses;
}

}  // namespace hazmap::pipeline_detail
