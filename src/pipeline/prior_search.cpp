#include "pipeline/prior_search.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "pipeline/clock.hpp"
#include "pipeline/loop_edges.hpp"
#include "pipeline/map_folder_output.hpp"
#include "pipeline/prior_overview.hpp"

namespace hazmap::pipeline_detail {

namespace {

// Keyframe clouds are kept at loop closure's default keyframe voxel; the prior's overview (the
// global registration target, prior_overview.hpp) is coarser.
constexpr double kKeyframeVoxel = 0.15;
// A query = the keyframe and this many before it (a VLP-16 scan alone is sparse).
constexpr std::size_t kQueryKeyframesBefore = 2;
// Where the descriptors cannot tell places apart (global registration ambiguous: a field of
// identical tanks), a stretch of this many keyframes before the query is placed by the
// correlative search instead, among the places within kStretchReach m of the prior's keyframes.
constexpr std::size_t kStretchKeyframesBefore = 12;
constexpr double kStretchReach = 3.0;
// Verification target: the nearest prior keyframe and this many on each side. In an open field
// a query's far floor and the tanks seen across it reach beyond a few prior keyframes' view:
// with 2 each side the tanks' right answers verified at fitness 0.70–0.79 (< 0.80), with 5 the
// placement of 2 of 16 tanks missions was not confirmed (27 of 57 loops verified); 8 confirms them.
constexpr std::size_t kPriorSubmapHalf = 8;
// The nearest prior keyframe must lie within this of the guess (m), else the run is elsewhere.
constexpr double kPriorReach = 6.0;
// Two answers localise the run when they agree this well (composed with the run's estimate).
constexpr double kAgreeTranslation = 0.3;               // m
constexpr double kAgreeRotation = 2.0 * M_PI / 180.0;   // rad

double median(std::vector<double> v) {
  std::erase_if(v, [](double x) { return !std::isfinite(x); });
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

bool agree(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return translationNorm(d) <= kAgreeTranslation && rotationAngle(d) <= kAgreeRotation;
}

// After localisation, a loop to the prior may correct the prediction by at most this much: more
// means the registration found another place, not this one.
constexpr double kLoopMaxCorrection = 0.5;        // m
constexpr double kLoopMaxCorrectionAngle = 0.05;  // rad
// A placement stands only when at least this share of the keyframes that land among the prior's
// verify there: two agreeing answers are not enough where a place looks like one not in the map
// (a 30-frame corridor map was placed in naraha's corridor with 10 of 25 verified; the naraha
// missions verify 92–99 %, the real KITTI halves 2 of 3).
constexpr double kMinConfirmedShare = 0.5;
// Floors on a loop-to-prior edge's standard deviations (as the map anchors', SlamConfig): the ICP
// covariance alone is over-confident.
constexpr double kLoopSigmaTranslation = 0.02, kLoopSigmaRotation = 0.002;

Matrix6d loopInformation(const Matrix6d& covariance) {
  Matrix6d c = covariance;
  Vector6d floor;
  floor << Eigen::Vector3d::Constant(kLoopSigmaTranslation * kLoopSigmaTranslation),
      Eigen::Vector3d::Constant(kLoopSigmaRotation * kLoopSigmaRotation);
  c += Matrix6d(floor.asDiagonal());
  return c.inverse();
}

}  // namespace

LabeledCloud RunKeyframes::query(std::size_t k, const FramePoses& poses) const {
  return query(k, poses, kQueryKeyframesBefore);
}

LabeledCloud RunKeyframes::query(std::size_t k, const FramePoses& poses, std::size_t before) const {
  const Eigen::Isometry3d world_k = poses.at(frames.at(k));
  LabeledCloud q = clouds.at(k);
  for (std::size_t j = k > before ? k - before : 0; j < k; ++j)
    q.append(clouds[j].transformed(world_k.inverse() * poses.at(frames[j])));
  return q;
}

void RunKeyframes::add(std::size_t frame, const LabeledCloud& full, const ClassTable& classes) {
  frames.push_back(frame);
  heights.push_back(sensorHeightAboveFloor(full));
  clouds.push_back(downsampledForPrior(full, kKeyframeVoxel, classes));
}

double RunKeyframes::sensorHeight() const { return median(heights); }

RunKeyframes readRunKeyframes(ScanSource& scans, const SlamResult& result, const SlamConfig& config,
                              const ClassTable& classes) {
  RunKeyframes run;
  const std::vector<std::size_t> frames = keyframeFrames(result, config);
  std::size_t i = 0, next = 0;
  for (std::optional<Scan> scan; next < frames.size() && (scan = scans.next()); ++i) {
    if (frames[next] != i) continue;
    ++next;
    redoDeskew(scan->cloud, result.frames.at(i));
    run.add(i, scan->cloud, classes);
  }
  return run;
}

RunKeyframes mapKeyframes(const MapFolder& map, const ClassTable& classes) {
  RunKeyframes run;
  for (std::size_t k = 0; k < map.keyframes().size(); ++k) run.add(map.keyframes()[k].frame, map.loadKeyframe(k), classes);
  return run;
}

PriorIndex::PriorIndex(const SlamConfig& config) : global_(config.odometry.global) {
  global_.tracking_registration = config.odometry.registration;
  global_.use_classes = global_.use_classes && config.odometry.registration.use_classes;
}

PriorIndex::PriorIndex(const MapFolder& prior, const ClassTable& classes, const SlamConfig& config)
    : PriorIndex(config) {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::size_t> tags;
  for (const auto& k : prior.keyframes()) poses.push_back(k.pose), tags.push_back(k.frame);
  std::optional<LabeledCloud> stored = storedSearchOverview(prior, classes);
  if (!stored) {
    add(prior, poses, tags, classes);
    prepare(classes, prior.dir().string());
    return;
  }
  poses_ = std::move(poses);
  tags_ = std::move(tags);
  segments_.assign(poses_.size(), 0);
  segment_count_ = 1;
  clouds_.resize(poses_.size());
  lazy_map_ = std::make_shared<const MapFolder>(prior);
  lazy_classes_ = std::make_shared<const ClassTable>(classes);
  prepareTarget(*stored, classes, prior.dir().string());
  used_stored_overview_ = true;
}

void PriorIndex::add(const MapFolder& map, const std::vector<Eigen::Isometry3d>& poses,
                     const std::vector<std::size_t>& tags, const ClassTable& classes) {
  if (lazy_map_) throw std::logic_error("PriorIndex::add on an index prepared from a stored overview");
  for (std::size_t k = 0; k < map.keyframes().size(); ++k) {
    const LabeledCloud full = map.loadKeyframe(k);
    poses_.push_back(poses.at(k));
    tags_.push_back(tags.at(k));
    segments_.push_back(segment_count_);
    clouds_.emplace_back(downsampledForPrior(full, kKeyframeVoxel, classes));
    overview_clouds_.push_back(keyframeOverview(full, classes));
  }
  ++segment_count_;
}

void PriorIndex::prepare(const ClassTable& classes, const std::string& where) {
  if (lazy_map_) throw std::logic_error("PriorIndex::prepare on an index prepared from a stored overview");
  SearchOverviewBuilder all(classes);
  for (std::size_t k = 0; k < poses_.size(); ++k) all.add(overview_clouds_[k], poses_[k]);
  prepareTarget(all.finish(), classes, where);
}

void PriorIndex::prepareTarget(const LabeledCloud& overview, const ClassTable& classes, const std::string& where) {
  if (poses_.empty()) fail(where, "the prior map has no keyframes");
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : poses_) centre += p.translation();
  centre /= static_cast<double>(poses_.size());
  overview_ = prepareGlobalTarget(overview, classes, global_, centre.cast<float>());
  footprint_ = CorrelativeTarget(overview, centre.z(), classes);
}

std::vector<Eigen::Vector2d> PriorIndex::places() const {
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : poses_) out.push_back(p.translation().head<2>());
  return out;
}

const LabeledCloud& PriorIndex::cloud(std::size_t k) const {
  std::lock_guard lock(clouds_mutex_);
  std::optional<LabeledCloud>& c = clouds_.at(k);
  if (!c) c = downsampledForPrior(lazy_map_->loadKeyframe(k), kKeyframeVoxel, *lazy_classes_);
  return *c;
}

std::size_t PriorIndex::keyframesRead() const {
  std::lock_guard lock(clouds_mutex_);
  return static_cast<std::size_t>(std::count_if(clouds_.begin(), clouds_.end(), [](const auto& c) { return c.has_value(); }));
}

std::size_t PriorIndex::nearest(const Eigen::Vector3d& position, double& distance) const {
  std::size_t best = 0;
  distance = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < poses_.size(); ++k) {
    const double d = (poses_[k].translation() - position).norm();
    if (d < distance) distance = d, best = k;
  }
  return best;
}

LabeledCloud PriorIndex::submap(std::size_t k) const {
  LabeledCloud s;
  const std::size_t first = k > kPriorSubmapHalf ? k - kPriorSubmapHalf : 0;
  const std::size_t last = std::min(poses_.size() - 1, k + kPriorSubmapHalf);
  for (std::size_t j = first; j <= last; ++j)
    if (segments_[j] == segments_[k]) s.append(cloud(j).transformed(poses_[k].inverse() * poses_[j]));
  return s;
}

PriorVerification verifyInPrior(const PriorIndex& prior, const LabeledCloud& query, const Eigen::Isometry3d& guess,
                                const ClassTable& classes, const SlamConfig& config) {
  PriorVerification v;
  double distance = 0.0;
  v.prior_keyframe = prior.nearest(guess.translation(), distance);
  if (distance > kPriorReach) {
    v.outcome = fmt::format("no prior keyframe within {:.0f} m of the answer", kPriorReach);
    return v;
  }
  v.in_reach = true;
  const LoopClosureConfig loops = loopClosureConfigFor(config);
  const VerificationConfig& vc = loops.verification;
  const Eigen::Isometry3d& P = prior.pose(v.prior_keyframe);
  v.registration = registerClouds(query, prior.submap(v.prior_keyframe), P.inverse() * guess, classes, vc.icp());
  const RegistrationResult& r = v.registration;
  v.T_world_query = P * r.transform;
  if (!r.converged) v.outcome = "property ICP did not converge: " + r.reason;
  else if (r.fitness < vc.min_fitness) v.outcome = fmt::format("property ICP fitness {:.2f} < {:.2f}", r.fitness, vc.min_fitness);
  else if (r.inlier_rmse > vc.max_rmse) v.outcome = fmt::format("property ICP rmse {:.2f} m > {:.2f} m", r.inlier_rmse, vc.max_rmse);
  else if (vc.reject_degenerate && !r.degenerate_directions.empty()) v.outcome = "property ICP leaves a direction degenerate";
  else {
    v.accepted = true;
    v.outcome = fmt::format("verified against prior keyframe {} (fitness {:.2f}, rmse {:.3f} m)", v.prior_keyframe,
                            r.fitness, r.inlier_rmse);
  }
  return v;
}

namespace {

// Where global registration places keyframe k's short `query`, or — where it found the place
// ambiguous — where the correlative search places a longer stretch of keyframes; nullopt when
// neither answers. `outcome` says which did what.
std::optional<Eigen::Isometry3d> placeQuery(const PriorIndex& prior, const RunKeyframes& run, std::size_t k,
                                           const LabeledCloud& query, const FramePoses& poses, const ClassTable& classes,
                                           std::string& outcome) {
  const GlobalRegistrationResult g = registerGlobally(query, prior.overview(), classes, prior.globalConfig());
  if (g.success) return g.transform;
  outcome = std::string("global registration: ") + toString(g.status) + (g.reason.empty() ? "" : " (" + g.reason + ")");
  if (g.status != GlobalStatus::Ambiguous) return std::nullopt;
  const CorrelativeResult c = searchCorrelative(run.query(k, poses, kStretchKeyframesBefore), prior.footprint(),
                                                prior.places(), kStretchReach, classes);
  outcome += "; correlative search of " + std::to_string(std::min(k, kStretchKeyframesBefore) + 1) + " keyframes: " + c.reason;
  if (!c.success) return std::nullopt;
  outcome += "; ";
  return c.transform;
}

}  // namespace

void searchPrior(const PriorIndex& prior, const RunKeyframes& run, const FramePoses& poses, const ClassTable& classes,
                 const SlamConfig& config, PriorLocalisation& out) {
  std::optional<std::pair<std::size_t, Eigen::Isometry3d>> last;  // keyframe, prior ← run
  double attempt_seconds = 0.0;
  for (std::size_t k = 0; k < run.frames.size(); ++k) {
    const auto t = Clock::now();
    const std::size_t f = run.frames[k];
    const LabeledCloud query = run.query(k, poses);
    PriorAttempt a{f, false, "", 0};
    const std::optional<Eigen::Isometry3d> guess = placeQuery(prior, run, k, query, poses, classes, a.outcome);
    if (guess) {
      const PriorVerification v = verifyInPrior(prior, query, *guess, classes, config);
      a.prior_keyframe = v.prior_keyframe;
      a.outcome += v.outcome;
      a.accepted = v.accepted;
      a.pose = v.T_world_query;
      if (v.accepted) {
        const Eigen::Isometry3d H = v.T_world_query * poses.at(f).inverse();
        // Two verified answers of two keyframes must agree (composed with the run's estimate).
        if (last && agree(last->second, H)) {
          out.state = PriorState::Localised;
          out.frame = f;
          out.T_prior_run = H;
          out.localised_pose = v.T_world_query;
          a.outcome += "; agrees with frame " + std::to_string(run.frames[last->first]) + "'s answer: localised";
        } else if (last) {
          a.outcome += "; disagrees with frame " + std::to_string(run.frames[last->first]) + "'s answer";
        }
        last.emplace(k, H);
      }
    }
    attempt_seconds += secondsSince(t);
    out.search.push_back(std::move(a));
    if (out.state == PriorState::Localised) break;
  }
  out.seconds_per_attempt = out.search.empty() ? 0.0 : attempt_seconds / static_cast<double>(out.search.size());
}

std::vector<PriorEdge> loopsToPrior(const PriorIndex& prior, const RunKeyframes& run, const FramePoses& poses,
                                    const ClassTable& classes, const SlamConfig& config, PriorLocalisation& out) {
  std::vector<PriorEdge> edges;
  for (std::size_t k = 0; k < run.frames.size(); ++k) {
    const std::size_t f = run.frames[k];
    const Eigen::Isometry3d predicted = poses.at(f);
    const PriorVerification v = verifyInPrior(prior, run.query(k, poses), predicted, classes, config);
    PriorAttempt a{f, false, v.outcome, v.prior_keyframe, v.T_world_query, v.in_reach};
    const Eigen::Isometry3d correction = predicted.inverse() * v.T_world_query;
    if (v.accepted && (translationNorm(correction) > kLoopMaxCorrection || rotationAngle(correction) > kLoopMaxCorrectionAngle))
      a.outcome = "moves the keyframe too far from where the localisation puts it";
    else if (v.accepted) {
      a.accepted = true;
      edges.push_back({v.prior_keyframe, f, prior.pose(v.prior_keyframe).inverse() * v.T_world_query,
                       loopInformation(v.registration.covariance)});
    }
    out.loops.push_back(std::move(a));
  }
  return edges;
}

bool placementConfirmed(const std::vector<PriorEdge>& edges, const std::string& prior, PriorLocalisation& out) {
  std::size_t in_reach = 0;
  for (const auto& a : out.loops) in_reach += a.in_reach;
  if (!edges.empty() && static_cast<double>(edges.size()) >= kMinConfirmedShare * static_cast<double>(in_reach))
    return true;
  out.optimisation_note = fmt::format("placement at frame {} not confirmed: {} of its {} keyframes that land in {} "
                                      "verified there",
                                      out.frame, edges.size(), in_reach, prior);
  out.state = PriorState::NeverLocalised;
  for (auto& a : out.loops)
    if (a.accepted) a.accepted = false, a.outcome += " (placement not confirmed: not used)";
  return false;
}

}  // namespace hazmap::pipeline_detail
