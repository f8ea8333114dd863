#include "odometry/motion_hypotheses.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

#include "hazmap/core/se3.hpp"
#include "hazmap/core/stable_sort.hpp"
#include "hazmap/preprocess/spatial_index.hpp"
#include "hazmap/registration/registration.hpp"

namespace hazmap {
namespace {

/// Source points scored per hypothesis: enough that a turn's misfit shows above the ground's
/// rotation-invariant share, few enough that an easy frame pays ~0.1 ms (bench_tracking_stress).
constexpr std::size_t kScorePoints = 384;
/// m; a sampled point this close to a target point fits. Half the default 1 m correspondence
/// gate: a start within the gate but a few degrees off still scores below the right one.
constexpr float kScoreGate = 0.5f;
/// The guess is searched around when it scores below this × the running score of the starts
/// before (a turn drops it to 0.3–0.6 ×; scene changes of easy frames stay above ~0.85 ×).
constexpr double kPoorRatio = 0.8;
/// Another start replaces the guess only when it scores this much higher: an easy frame whose
/// guess is merely a bit worse keeps it (and its results) unchanged.
constexpr double kMinGain = 0.05;
/// rad; the sweep's step: ICP from a start within half of it converges on real scans (KITTI:
/// within 5 deg at the 1 m gate).
constexpr double kCoarseYawStep = 10.0 * M_PI / 180.0;
/// A scan with fewer points than this keeps its guess: too few to tell hypotheses apart (a
/// 30-point scan was "tracked" from a refined start instead of recovered or flagged).
constexpr std::size_t kMinScanPoints = 200;
/// m; the translation grid's step when no motion is known yet (the first step, frames dropped
/// before it): a start within half a diagonal (0.7 m) of the right one converges in the refinement.
constexpr double kGridStep = 1.0;
/// No motion known yet (the first step): a guess whose own refinement fits this share of the
/// sample lies in the right basin, and the other starts are not scored. The right basin's
/// refinement scored 0.64-0.79 on the shared real scans and 0.75-0.91 on the simulated worst
/// days; wrong basins 0.12-0.28 (real: turned 10-45 deg, 3.5 m unknown travel) and 0.53 (naraha's
/// worst day without wheels, a refinement stuck at the start; docs/registration.md). A scene
/// where even the right basin fits worse pays the whole search, as before.
constexpr double kRightBasin = 0.6;
/// Weight of a new frame in the running score.
constexpr double kTypicalWeight = 0.2;
/// The best-scoring starts refined by a short ICP of the sampled points: a raw score ranks a
/// start 14 deg off above the right one on a street whose walls run alike (KITTI turned 30 deg),
/// and barely tells turns apart where the floor and ceiling dominate (the Ouster capture); after
/// a few ICP steps the right basin fits clearly best.
constexpr std::size_t kRefined = 3;
constexpr int kRefineIterations = 15;

struct Candidate {
  Eigen::Isometry3d increment;
  std::string name;
  double score = 0.0;
};

Eigen::Isometry3d yawed(const Eigen::Isometry3d& increment, double yaw) {
  Eigen::Isometry3d T = increment;
  T.linear() = increment.linear() * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

std::string sweepName(double yaw) {
  char s[48];
  std::snprintf(s, sizeof s, "yaw sweep %+.1f deg", yaw * 180.0 / M_PI);
  return s;
}

LabeledCloud sampleOf(const LabeledCloud& source) {
  const std::size_t stride = std::max<std::size_t>(1, (source.size() + kScorePoints - 1) / kScorePoints);
  LabeledCloud out;
  for (std::size_t i = 0; i < source.size(); i += stride) out.push_back(source.points[i], source.classes[i]);
  return out;
}

// hypothesisScore from one index of every target point: the score reads only the distance to
// the nearest target point of any class, which this finds as exactly as the target's per-class
// indexes (a minimum does not depend on where it is searched), with one search instead of one per
// class. Built once a search runs (dozens of starts), not for the guess's score alone.
double anyClassScore(const LabeledCloud& sample, const VoxelHashIndex& all, float radius,
                     const Eigen::Isometry3d& pose) {
  if (sample.empty()) return 0.0;
  const Eigen::Isometry3f T = pose.cast<float>();
  const float gate2 = kScoreGate * kScoreGate;
  const float bound = std::min(radius * radius, gate2);  // nearestAnyClass's bound
  double sum = 0.0;
  for (std::size_t i = 0; i < sample.size(); ++i) {
    float d2 = 0.0f;
    if (all.nearest(T * sample.points[i], bound, d2) >= 0 && d2 <= gate2) sum += 1.0 - d2 / gate2;
  }
  return sum / static_cast<double>(sample.size());
}

// Scores every candidate (in parallel; each score is independent, so the result is deterministic).
void scoreAll(std::vector<Candidate>& cands, std::size_t from, const LabeledCloud& sample,
              const VoxelHashIndex& all, float radius, const Eigen::Isometry3d& previous) {
  tbb::parallel_for(from, cands.size(), [&](std::size_t i) {
    cands[i].score = anyClassScore(sample, all, radius, previous * cands[i].increment);
  });
}

std::size_t bestOf(const std::vector<Candidate>& cands) {
  std::size_t best = 0;
  for (std::size_t i = 1; i < cands.size(); ++i)
    if (cands[i].score > cands[best].score) best = i;  // ties: the earlier (simpler) hypothesis
  return best;
}

// The hypotheses besides the guess: zero motion, the last translation without its turn, the
// IMU's rotation with the guess's translation.
void addBaseHypotheses(std::vector<Candidate>& cands, const HypothesisInputs& in) {
  cands.push_back({Eigen::Isometry3d::Identity(), "zero motion"});
  if (in.last_increment) {
    Eigen::Isometry3d straight = Eigen::Isometry3d::Identity();
    straight.translation() = in.last_increment->translation();
    cands.push_back({straight, "last translation, no turn"});
  }
  if (in.imu_rotation) {
    Eigen::Isometry3d imu = in.guess;
    imu.linear() = in.imu_rotation->normalized().toRotationMatrix();
    cands.push_back({imu, "IMU rotation"});
  }
}

// A yaw sweep around `centre`, coarse steps over ±range.
void sweepYaw(std::vector<Candidate>& cands, Candidate centre, double range) {  // a copy: cands grows
  for (double yaw = kCoarseYawStep; yaw <= range + 1e-9; yaw += kCoarseYawStep)
    for (double s : {yaw, -yaw}) cands.push_back({yawed(centre.increment, s), sweepName(s)});
}

// No motion known yet: horizontal steps of kGridStep within the plausible travel around `centre`
// (at its turn), in the previous frame.
void addTranslationGrid(std::vector<Candidate>& cands, Candidate centre, double reach) {  // a copy: cands grows
  const int n = static_cast<int>(std::floor(reach / kGridStep));
  for (int i = -n; i <= n; ++i)
    for (int j = -n; j <= n; ++j) {
      const Eigen::Vector3d step(i * kGridStep, j * kGridStep, 0.0);
      if ((i == 0 && j == 0) || step.norm() > reach) continue;
      Eigen::Isometry3d T = centre.increment;
      T.translation() += step;
      char s[64];
      std::snprintf(s, sizeof s, "translation grid %+.0f %+.0f m", step.x(), step.y());
      cands.push_back({T, s});
    }
}

struct Refinement {
  int passes = 0;  ///< the ICP's searches of the sample, +1 when scored again
  std::optional<Eigen::Isometry3d> answer;  ///< registration space ← source; none when ICP failed
};

// The short ICP of the sample (registration space ← previous frame `previous`) from `c`: `c`
// moved to its answer (not yet scored again), or unchanged when it failed.
Refinement refineCandidate(Candidate& c, const LabeledCloud& sample, const RegistrationTarget& target,
                           const Eigen::Isometry3d& previous, const ClassTable& classes, const RegistrationConfig& icp) {
  RegistrationConfig rc = icp;
  rc.max_iterations = kRefineIterations;
  rc.coarse_source_points = 0;
  rc.max_source_points = 0;
  rc.threads = 1;  // the candidates run in parallel
  const RegistrationResult r = registerClouds(sample, target, previous * c.increment, classes, rc);
  if (r.termination != Termination::Converged && r.termination != Termination::MaxIterations) return {r.iterations, {}};
  c.increment = previous.inverse() * r.transform;
  c.name += ", refined";
  return {r.iterations + 1, r.transform};
}

// The guess, refined, and the kRefined best other candidates, each refined and scored again; the
// guess stays first.
std::vector<Candidate> refineBest(std::vector<Candidate> cands, const Candidate& refined_guess,
                                  const LabeledCloud& sample, const RegistrationTarget& target,
                                  const VoxelHashIndex& all, const Eigen::Isometry3d& previous,
                                  const ClassTable& classes, const RegistrationConfig& icp, std::size_t& searches) {
  // Candidate holds an Isometry3d: not std::stable_sort (its scratch buffer is under-aligned for
  // -march=native Eigen; include/hazmap/core/stable_sort.hpp). The guess stays first.
  cands.erase(cands.begin());
  stableSortAligned(cands, [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  cands.insert(cands.begin(), refined_guess);
  cands.resize(std::min(cands.size(), kRefined + 1));
  std::vector<int> passes(cands.size(), 0);
  tbb::parallel_for(std::size_t{1}, cands.size(), [&](std::size_t i) {
    const Refinement r = refineCandidate(cands[i], sample, target, previous, classes, icp);
    passes[i] = r.passes;
    if (r.answer) cands[i].score = anyClassScore(sample, all, target.defaultRadius(), *r.answer);
  });
  for (const int p : passes) searches += static_cast<std::size_t>(p) * sample.size();
  return cands;
}

// The other hypotheses, appended to `cands` (the guess first) and scored: zero motion, the last
// translation without its turn, the IMU's rotation, a yaw sweep around the best of them and, with
// no motion known yet (the first step, frames dropped before it), a translation grid around the
// best of those. Repeating the last increment for frames dropped mid-run was tried and not adopted
// (docs/history/2026-12-03-repeated-increments.md). Returns the searches made.
std::size_t scoreOthers(std::vector<Candidate>& cands, const HypothesisInputs& in, const LabeledCloud& sample,
                        const VoxelHashIndex& all, float radius, const Eigen::Isometry3d& previous,
                        const HypothesisLimits& limits, const MotionHypothesisConfig& config) {
  addBaseHypotheses(cands, in);
  scoreAll(cands, 1, sample, all, radius, previous);
  const std::size_t base = cands.size();
  sweepYaw(cands, cands[bestOf(cands)], std::min(config.yaw_range, limits.plausible_rotation));
  scoreAll(cands, base, sample, all, radius, previous);
  const std::size_t swept = cands.size();
  if (!in.last_increment) addTranslationGrid(cands, cands[bestOf(cands)], limits.plausible_translation);
  scoreAll(cands, swept, sample, all, radius, previous);
  return cands.size() * sample.size();
}

// The start the full ICP should use instead of the guess, or nothing (keep the guess): another
// start whose refinement fits clearly better than the guess's own (the guess lies in a wrong
// basin), or the guess's refinement when it moved beyond the tracking checks' correction limits
// and fits clearly better than the guess (ICP from the guess would fail those checks: a dropped
// frame with no motion known). A guess whose own basin is right is never replaced, so the
// tracking prior kept along degenerate directions stays the wheels' or constant velocity's.
const Candidate* pickStart(const Candidate& guess, const std::vector<Candidate>& refined,
                           const HypothesisLimits& limits) {
  const std::size_t best = bestOf(refined);
  if (best != 0 && refined[best].score >= refined[0].score + kMinGain) return &refined[best];
  const Eigen::Isometry3d moved = guess.increment.inverse() * refined[0].increment;
  const bool beyond = translationNorm(moved) > limits.max_translation || rotationAngle(moved) > limits.max_rotation;
  if (beyond && refined[0].score >= guess.score + kMinGain) return &refined[0];
  return nullptr;
}

}  // namespace

double hypothesisScore(const LabeledCloud& sample, const RegistrationTarget& target, const Eigen::Isometry3d& pose) {
  if (sample.empty()) return 0.0;
  const Eigen::Isometry3f T = pose.cast<float>();
  const float gate2 = kScoreGate * kScoreGate;
  double sum = 0.0;
  for (std::size_t i = 0; i < sample.size(); ++i) {
    const TargetMatch m = target.nearestAnyClass(T * sample.points[i], sample.classes[i], gate2);
    if (m.index >= 0 && m.distance2 <= gate2) sum += 1.0 - m.distance2 / gate2;
  }
  return sum / static_cast<double>(sample.size());
}

HypothesisChoice MotionHypotheses::choose(const LabeledCloud& source, const RegistrationTarget& target,
                                          const Eigen::Isometry3d& previous, const HypothesisInputs& in,
                                          const ClassTable& classes, const RegistrationConfig& icp,
                                          const HypothesisLimits& limits, const MotionHypothesisConfig& config) {
  const auto t0 = std::chrono::steady_clock::now();
  HypothesisChoice out;
  const LabeledCloud sample = sampleOf(source);
  std::vector<Candidate> cands{{in.guess, in.guess_name, 0.0}};
  cands[0].score = hypothesisScore(sample, target, previous * in.guess);
  out.guess_score = out.score = cands[0].score;
  out.increment = in.guess;
  out.name = in.guess_name;
  if (source.size() >= kMinScanPoints && (typical_ <= 0.0 || out.guess_score < kPoorRatio * typical_)) {
    out.searched = true;
    const Candidate guess = cands[0];
    const float radius = target.defaultRadius();
    // The guess's own refinement, and meanwhile the index of every target point the scores read.
    Candidate refined_guess = cands[0];
    Refinement guess_refinement;
    std::optional<VoxelHashIndex> all;
    tbb::parallel_invoke(
        [&] { guess_refinement = refineCandidate(refined_guess, sample, target, previous, classes, icp); },
        [&] { all.emplace(target.cloud().points, std::span<const std::uint32_t>{}, kScoreGate, std::min(radius, kScoreGate)); });
    if (guess_refinement.answer) refined_guess.score = anyClassScore(sample, *all, radius, *guess_refinement.answer);
    out.searches = static_cast<std::size_t>(guess_refinement.passes) * sample.size();
    std::vector<Candidate> refined;
    if (typical_ <= 0.0 && refined_guess.score >= kRightBasin) {
      out.scored = 1;
      out.searches += sample.size();
      refined.push_back(refined_guess);
    } else {
      out.searches += scoreOthers(cands, in, sample, *all, radius, previous, limits, config);
      out.scored = static_cast<int>(cands.size());
      refined = refineBest(std::move(cands), refined_guess, sample, target, *all, previous, classes, icp, out.searches);
    }
    if (const Candidate* start = pickStart(guess, refined, limits)) {
      out.increment = start->increment;
      out.name = start->name;
      out.score = start->score;
      out.replaced = true;
    }
  }
  if (!out.searched) out.searches = sample.size();
  typical_ = typical_ > 0.0 ? (1.0 - kTypicalWeight) * typical_ + kTypicalWeight * out.score : out.score;
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace hazmap
