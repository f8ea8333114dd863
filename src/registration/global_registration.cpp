// Global registration: target preparation, descriptor matching, hypothesis scoring, ICP
// refinement and the ambiguity test (see include/hazmap/registration/global_registration.hpp).
#include "hazmap/registration/global_registration.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>

#include "global_internal.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/stable_sort.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "thread_arena.hpp"

namespace hazmap {

// Internal thresholds of global registration (issue 37: named constants, not keys; their old
// keys name this file). docs/registration.md, "Global registration".
/// Match at most this many source descriptors (even stride; labelled ones always): a dense scan has far more than RANSAC needs.
constexpr std::size_t kMaxSourceFeatures = 3000;
/// Keep only mutual nearest neighbours in descriptor space (when at least kMinCorrespondences).
constexpr bool kMutualFilter = true;
/// Mutual matches needed before the mutual filter is trusted.
constexpr std::size_t kMinCorrespondences = 10;
/// Score = (1 − share)·overlap + share·(labelled points on their class): the labels weigh as a whole, so a few property points break a symmetry thousands of geometric points cannot.
constexpr double kLabelScoreShare = 0.3;
/// Labelled source points (in landmarks) needed for the label term of the score.
constexpr std::size_t kMinLabelledPoints = 3;
/// A winner on which fewer labelled points land on their own class than this share matched the wrong place.
constexpr double kMinLabelAgreement = 0.2;
/// Downsampled source/target points needed: fewer cannot tell places apart.
constexpr std::size_t kMinPoints = 50;
/// Points with a descriptor needed.
constexpr std::size_t kMinFeatures = 30;
/// A distinct second hypothesis scoring >= this × the best makes the result ambiguous (not accepted).
constexpr double kAmbiguityRatio = 0.9;
/// Refuse a winner whose refinement ICP leaves directions unconstrained (a bare plane, a featureless corridor).
constexpr bool kRejectDegenerate = true;
/// Distinct hypotheses refined by ICP: the best and its rival (the ambiguity test needs both).
constexpr int kCandidatesRefined = 2;


GlobalRegistrationTarget::GlobalRegistrationTarget() : impl_(std::make_unique<Impl>()) {}
GlobalRegistrationTarget::~GlobalRegistrationTarget() = default;
GlobalRegistrationTarget::GlobalRegistrationTarget(GlobalRegistrationTarget&&) noexcept = default;
GlobalRegistrationTarget& GlobalRegistrationTarget::operator=(GlobalRegistrationTarget&&) noexcept = default;
std::size_t GlobalRegistrationTarget::size() const { return impl_->features.cloud.size(); }
std::size_t GlobalRegistrationTarget::features() const { return impl_->features.feature_point.size(); }
std::size_t GlobalRegistrationTarget::landmarks() const { return impl_->landmarks.size(); }

namespace {

using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

RegistrationConfig refinementOf(const GlobalRegistrationConfig& config) {
  RegistrationConfig r = config.refinementIcp();
  r.use_classes = config.use_classes;
  r.threads = 0;  // runs inside the caller's arena
  return r;
}

// The winner's last step: the refinement ICP on finer clouds. Kept only if it converged and
// moved little (a polish, not a new answer).
void polish(GlobalRegistrationResult& r, const LabeledCloud& source, const GlobalRegistrationTarget::Impl& tgt,
            const ClassTable& classes, const GlobalRegistrationConfig& config) {
  if (!tgt.final_icp || !r.success) return;
  const LabeledCloud fine = voxelDownsample(source, propertyVoxels(config.final_voxel_size), classes);
  const RegistrationResult p = registerClouds(fine, *tgt.final_icp, r.transform, classes, refinementOf(config));
  const bool usable = p.termination == Termination::Converged || p.termination == Termination::MaxIterations;
  if (!usable || !isFinite(p.transform) || global::distinct(p.transform, r.transform)) return;
  r.transform = p.transform;
  r.refinement = p;
}

bool sameFeatures(const GlobalRegistrationConfig& a, const GlobalRegistrationConfig& b) {
  return a.voxel_size == b.voxel_size && a.normal_radius == b.normal_radius &&
         a.normal_neighbors == b.normal_neighbors && a.feature_radius == b.feature_radius &&
         a.max_range == b.max_range && a.use_classes == b.use_classes && a.final_voxel_size == b.final_voxel_size;
}

// Source descriptor → nearest target descriptor (own class for labelled points, property-aware);
// with the mutual filter, kept only when that target descriptor's nearest source is the same.
std::vector<global::Match> matchDescriptors(const global::FeatureCloud& src, const GlobalRegistrationTarget::Impl& tgt,
                                            const ClassTable& classes, const GlobalRegistrationConfig& config) {
  const auto& tf = tgt.features;
  const std::size_t n = src.descriptors.size();
  std::vector<std::int64_t> forward(n, -1);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f)
      forward[f] = global::nearestFor(src.descriptors[f], src.cloud.classes[src.feature_point[f]], tgt.descriptors,
                                      classes, config.use_classes);
  });
  std::vector<global::Match> all, mutual;
  for (std::size_t f = 0; f < n; ++f)
    if (forward[f] >= 0) all.push_back({src.feature_point[f], tf.feature_point[forward[f]]});
  if (!kMutualFilter) return all;
  const global::DescriptorIndexes source_idx = global::indexDescriptors(src, classes, config.use_classes);
  std::vector<char> keep(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 64), [&](const auto& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      if (forward[f] < 0) continue;
      const auto t = static_cast<std::size_t>(forward[f]);
      keep[f] = global::nearestFor(tf.descriptors[t], tf.cloud.classes[tf.feature_point[t]], source_idx, classes,
                                   config.use_classes) == static_cast<std::int64_t>(f);
    }
  });
  for (std::size_t f = 0; f < n; ++f)
    if (keep[f]) mutual.push_back({src.feature_point[f], tf.feature_point[forward[f]]});
  // Too few mutual matches to trust: the one-way matches carry more inliers in absolute terms.
  return mutual.size() >= kMinCorrespondences ? mutual : all;
}

// Keeps at most max_source_features descriptors: every labelled one (property-aware) and an even
// stride over the rest.
void thinSourceFeatures(global::FeatureCloud& src, const ClassTable& classes, const GlobalRegistrationConfig& config) {
  const std::size_t n = src.descriptors.size();
  if (kMaxSourceFeatures == 0 || n <= kMaxSourceFeatures) return;
  const double step = static_cast<double>(n) / static_cast<double>(kMaxSourceFeatures);
  double next = 0.0;
  std::size_t kept = 0;
  for (std::size_t f = 0; f < n; ++f) {
    const bool labelled = config.use_classes && classes.isProperty(src.cloud.classes[src.feature_point[f]]);
    const bool on_stride = static_cast<double>(f) >= next;
    if (on_stride) next += step;
    if (!labelled && !on_stride) continue;
    src.descriptors[kept] = src.descriptors[f];
    src.feature_point[kept] = src.feature_point[f];
    ++kept;
  }
  src.descriptors.resize(kept);
  src.feature_point.resize(kept);
}

struct Score {
  double weighted = 0.0;  ///< what hypotheses are ranked by (see label_score_share)
  double overlap = 0.0;   ///< share of source points with a target point within inlier_distance
  double labels = 0.0;    ///< share of labelled source points with a same-class target point there
};

// `max_points` > 0: an even stride over the source of about that many points (ranking many
// hypotheses needs no more); 0 = every point. Labelled points are always all counted.
Score scoreOf(const Eigen::Isometry3d& T, const global::FeatureCloud& src, const GlobalRegistrationTarget::Impl& tgt,
              const GlobalRegistrationConfig& config, std::size_t max_points = 0) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  const float d2 = static_cast<float>(config.inlier_distance * config.inlier_distance);
  float dist2 = 0.0f;
  std::size_t hits = 0, used = 0;
  const std::size_t stride = max_points == 0 ? 1 : std::max<std::size_t>(1, src.cloud.size() / max_points);
  for (std::size_t i = 0; i < src.cloud.size(); i += stride, ++used)
    hits += tgt.overlap_points->nearest(R * src.cloud.points[i] + t, d2, dist2) >= 0;
  Score s;
  s.overlap = static_cast<double>(hits) / static_cast<double>(std::max<std::size_t>(used, 1));
  s.weighted = s.overlap;
  if (!config.use_classes || src.labelled.size() < kMinLabelledPoints) return s;
  std::size_t on_class = 0;
  for (std::uint32_t i : src.labelled) {
    const auto it = tgt.class_points.find(src.cloud.classes[i]);
    on_class += it != tgt.class_points.end() && it->second->nearest(R * src.cloud.points[i] + t, d2, dist2) >= 0;
  }
  s.labels = static_cast<double>(on_class) / static_cast<double>(src.labelled.size());
  s.weighted = (1.0 - kLabelScoreShare) * s.overlap + kLabelScoreShare * s.labels;
  return s;
}

std::size_t agreeingMatches(const Eigen::Isometry3d& T, const global::FeatureCloud& src,
                            const global::FeatureCloud& tgt, const std::vector<global::Match>& matches,
                            double distance) {
  std::size_t n = 0;
  for (const auto& m : matches)
    n += (T.cast<float>() * src.cloud.points[m.source] - tgt.cloud.points[m.target]).norm() < distance;
  return n;
}

}  // namespace

GlobalRegistrationTarget prepareGlobalTarget(const LabeledCloud& target, const ClassTable& classes,
                                             const GlobalRegistrationConfig& config, const Eigen::Vector3f& viewpoint) {
  config.validate();
  target.checkConsistent("global registration target");
  if (config.use_classes) classes.checkCloud(target, "global registration target");
  GlobalRegistrationTarget out;
  auto& impl = *out.impl_;
  impl.config = config;
  detail::runWithThreads(config.threads, [&] {
    impl.features = global::computeFeatures(target, classes, config, viewpoint);
    impl.descriptors = global::indexDescriptors(impl.features, classes, config.use_classes);
    const float r = static_cast<float>(config.inlier_distance);
    impl.overlap_points = std::make_unique<VoxelHashIndex>(impl.features.cloud.points, std::span<const std::uint32_t>{}, r, r);
    if (config.use_classes) {
      std::map<ClassId, std::vector<std::uint32_t>> per_class;
      for (std::uint32_t i = 0; i < impl.features.cloud.size(); ++i)
        if (classes.isProperty(impl.features.cloud.classes[i])) per_class[impl.features.cloud.classes[i]].push_back(i);
      for (auto& [c, ids] : per_class)
        impl.class_points.emplace(c, std::make_unique<VoxelHashIndex>(impl.features.cloud.points, ids, r, r));
      impl.landmarks = impl.features.landmarks;
    }
    impl.icp.emplace(impl.features.cloud, classes, refinementOf(config));
    if (config.final_voxel_size > 0.0)
      impl.final_icp.emplace(voxelDownsample(target, propertyVoxels(config.final_voxel_size), classes), classes, refinementOf(config));
  });
  return out;
}

namespace {

struct Candidate {
  global::Hypothesis hypothesis;
  Score score;
  RegistrationResult icp;
};

bool refined(const Candidate& c) { return c.icp.termination != Termination::NotRun; }

void refineOne(Candidate& c, const global::FeatureCloud& src, const GlobalRegistrationTarget::Impl& tgt,
               const ClassTable& classes, const GlobalRegistrationConfig& config) {
  c.icp = registerClouds(src.cloud, *tgt.icp, c.hypothesis.transform, classes, refinementOf(config));
  // ICP's answer replaces the hypothesis whenever it ran to a usable pose (the overlap count is
  // too coarse to judge centimetres); a failed ICP leaves the hypothesis.
  const bool usable = c.icp.termination == Termination::Converged || c.icp.termination == Termination::MaxIterations;
  if (usable && isFinite(c.icp.transform)) c.hypothesis.transform = c.icp.transform;
  c.score = scoreOf(c.hypothesis.transform, src, tgt, config);  // every point: the final word
}

// Refined first (the winner must be a refined one), each group by score; then pairwise distinct
// (candidates that ICP brought to the same pose are one).
void sortAndThin(std::vector<Candidate>& v) {
  stableSortAligned(v, [](const Candidate& a, const Candidate& b) {  // holds Isometry3d: not std::stable_sort
    return refined(a) != refined(b) ? refined(a) : a.score.weighted > b.score.weighted;
  });
  std::vector<Candidate> out;
  for (auto& c : v) {
    bool fresh = true;
    for (const auto& o : out) fresh = fresh && global::distinct(c.hypothesis.transform, o.hypothesis.transform);
    if (fresh) out.push_back(std::move(c));
  }
  v = std::move(out);
}

// Scores every hypothesis, refines the best few distinct ones by property ICP and rescores them
// on every point. A rival that could still make the result ambiguous is refined too before it
// counts (an unrefined score is a rough one). Returns distinct candidates, best first.
std::vector<Candidate> refineCandidates(const std::vector<global::Hypothesis>& hypotheses,
                                        const global::FeatureCloud& src, const GlobalRegistrationTarget::Impl& tgt,
                                        const ClassTable& classes, const GlobalRegistrationConfig& config) {
  std::vector<Candidate> scored(hypotheses.size());
  tbb::parallel_for(std::size_t{0}, hypotheses.size(), [&](std::size_t k) {
    constexpr std::size_t kRankingPoints = 800;
    scored[k] = {hypotheses[k], scoreOf(hypotheses[k].transform, src, tgt, config, kRankingPoints), {}};
  });
  sortAndThin(scored);
  // Refine the best few; none that scores below half the best (ICP would not lift it to a rival).
  std::size_t refine = std::min<std::size_t>(scored.size(), kCandidatesRefined);
  while (refine > 1 && scored[refine - 1].score.weighted < 0.5 * scored[0].score.weighted) --refine;
  tbb::parallel_for(std::size_t{0}, refine, [&](std::size_t k) { refineOne(scored[k], src, tgt, classes, config); });
  sortAndThin(scored);
  constexpr int kMoreRivals = 4;
  for (int extra = 0; extra < kMoreRivals && scored.size() > 1 && !refined(scored[1]); ++extra) {
    auto rival = std::find_if(scored.begin(), scored.end(), [](const Candidate& c) { return !refined(c); });
    if (rival->score.weighted < 0.5 * scored[0].score.weighted) break;
    refineOne(*rival, src, tgt, classes, config);
    sortAndThin(scored);
  }
  return scored;
}

GlobalRegistrationResult failWith(GlobalRegistrationResult r, GlobalStatus status, std::string reason) {
  r.success = false;
  r.status = status;
  r.reason = std::move(reason);
  return r;
}

std::string describeCounts(const char* what, std::size_t have, std::size_t need) {
  return std::string(what) + ": " + std::to_string(have) + " < " + std::to_string(need);
}

// The decision on the refined candidates: the best must overlap enough and stand out.
GlobalRegistrationResult decide(GlobalRegistrationResult r, const std::vector<Candidate>& c,
                                const GlobalRegistrationConfig& config) {
  if (c.empty()) return failWith(std::move(r), GlobalStatus::NoConsensus, "no hypothesis passed the checks");
  r.transform = c[0].hypothesis.transform;
  r.score = c[0].score.weighted;
  r.overlap = c[0].score.overlap;
  r.label_agreement = c[0].score.labels;
  r.refinement = c[0].icp;
  r.from_constellation = c[0].hypothesis.constellation;
  r.second_best_score = c.size() > 1 ? c[1].score.weighted : 0.0;
  char text[160];
  if (r.overlap < config.min_overlap) {
    std::snprintf(text, sizeof text, "best hypothesis overlaps %.0f %% of the scan (< %.0f %%)", 100 * r.overlap,
                  100 * config.min_overlap);
    return failWith(std::move(r), GlobalStatus::PoorOverlap, text);
  }
  if (r.second_best_score >= kAmbiguityRatio * r.score) {
    r.ambiguous = true;
    std::snprintf(text, sizeof text, "two distinct hypotheses score %.3f and %.3f (ratio >= %.2f)", r.score,
                  r.second_best_score, kAmbiguityRatio);
    return failWith(std::move(r), GlobalStatus::Ambiguous, text);
  }
  if (r.label_agreement < kMinLabelAgreement && c[0].score.weighted != c[0].score.overlap) {
    std::snprintf(text, sizeof text, "the property labels disagree: %.0f %% of the labelled points land on their class (< %.0f %%)",
                  100 * r.label_agreement, 100 * kMinLabelAgreement);
    return failWith(std::move(r), GlobalStatus::LabelsDisagree, text);
  }
  if (kRejectDegenerate && !r.refinement.degenerate_directions.empty()) {
    std::snprintf(text, sizeof text, "the geometry leaves %zu direction(s) of the pose unconstrained",
                  r.refinement.degenerate_directions.size());
    return failWith(std::move(r), GlobalStatus::Degenerate, text);
  }
  r.success = true;
  r.status = GlobalStatus::Success;
  return r;
}

GlobalRegistrationResult registerPrepared(const LabeledCloud& source, const GlobalRegistrationTarget::Impl& tgt,
                                          const ClassTable& classes, const GlobalRegistrationConfig& config) {
  GlobalRegistrationResult r;
  auto t0 = Clock::now();
  const auto start = t0;
  global::FeatureCloud src = global::computeFeatures(source, classes, config, Eigen::Vector3f::Zero());
  r.source_points = src.cloud.size();
  r.source_features = src.feature_point.size();
  r.timings.prepare_ms = msSince(t0);
  if (src.cloud.size() < kMinPoints)
    return failWith(std::move(r), GlobalStatus::TooFewPoints, describeCounts("too few source points", src.cloud.size(), kMinPoints));
  if (tgt.features.cloud.size() < kMinPoints)
    return failWith(std::move(r), GlobalStatus::TooFewPoints, describeCounts("too few target points", tgt.features.cloud.size(), kMinPoints));
  if (r.source_features < kMinFeatures || tgt.features.feature_point.size() < kMinFeatures)
    return failWith(std::move(r), GlobalStatus::TooFewFeatures,
                    describeCounts("too few features", std::min(r.source_features, tgt.features.feature_point.size()),
                                   kMinFeatures));
  t0 = Clock::now();
  thinSourceFeatures(src, classes, config);
  const std::vector<global::Match> matches = matchDescriptors(src, tgt, classes, config);
  r.correspondences = matches.size();
  r.timings.match_ms = msSince(t0);
  t0 = Clock::now();
  constexpr std::size_t kKeep = 32;
  std::vector<global::Hypothesis> hypotheses =
      global::ransacHypotheses(src.cloud.points, tgt.features.cloud.points, matches, config, kKeep);
  if (config.use_classes) {
    const auto constellations = global::constellationHypotheses(
        src.landmarks, tgt.landmarks, config, kKeep);
    r.constellation_hypotheses = constellations.size();
    hypotheses.insert(hypotheses.end(), constellations.begin(), constellations.end());
  }
  if (matches.size() < 3 && hypotheses.empty())
    return failWith(std::move(r), GlobalStatus::TooFewCorrespondences, describeCounts("too few correspondences", matches.size(), 3));
  r.timings.hypotheses_ms = msSince(t0);
  t0 = Clock::now();
  const std::vector<Candidate> candidates = refineCandidates(hypotheses, src, tgt, classes, config);
  r.timings.refine_ms = msSince(t0);
  r = decide(std::move(r), candidates, config);
  polish(r, source, tgt, classes, config);
  r.inliers = agreeingMatches(r.transform, src, tgt.features, matches, config.inlier_distance);
  r.timings.total_ms = msSince(start);
  return r;
}

}  // namespace

GlobalRegistrationResult registerGlobally(const LabeledCloud& source, const GlobalRegistrationTarget& target,
                                          const ClassTable& classes, const GlobalRegistrationConfig& config) {
  config.validate();
  if (!sameFeatures(config, target.impl().config))
    fail("global registration", "the target was prepared with other feature settings than the config given");
  source.checkConsistent("global registration source");
  if (config.use_classes) classes.checkCloud(source, "global registration source");
  GlobalRegistrationResult r;
  detail::runWithThreads(config.threads, [&] { r = registerPrepared(source, target.impl(), classes, config); });
  return r;
}

GlobalRegistrationResult registerGlobally(const LabeledCloud& source, const LabeledCloud& target,
                                          const ClassTable& classes, const GlobalRegistrationConfig& config) {
  return registerGlobally(source, prepareGlobalTarget(target, classes, config), classes, config);
}

}  // namespace hazmap
