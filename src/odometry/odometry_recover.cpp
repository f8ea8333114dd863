// Recovery of a frame whose tracking ICP failed or is suspect (issue 19): a guess-free global
// registration against the same target, plus ICP from a few other starts around the motion
// prior (no motion: the encoders' travel was a slip; the last increment again).
// Every answer is verified by the tracking ICP and its checks, and must be a plausible motion
// for the platform; the best one is used unless a distinct one fits as well (ambiguous).
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

#include "hazmap/registration/global_registration.hpp"
#include "odometry/odometry_checks.hpp"

namespace hazmap {

// Share of the source points that lie on a target surface at `pose` (W ← source): the nearest
// target point within the correspondence gate and the distance along its normal (or to it,
// without normals) at most `inlier_distance`. ICP's fitness counts partners within 1 m, which a
// wrong pose in a dense map still finds; a surface within a few centimetres it does not. The
// same measure scores the guess itself, which a recovery must beat (tanks seed 3: an answer
// from another start that fitted no better than the guess replaced it and was 5 cm worse).
double surfaceFit(const LabeledCloud& source, const RegistrationTarget& target, const Eigen::Isometry3d& pose,
                  double inlier_distance) {
  if (source.empty()) return 0.0;
  const Eigen::Isometry3f T = pose.cast<float>();
  const float tau = static_cast<float>(inlier_distance);
  std::size_t on_surface = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    const Eigen::Vector3f p = T * source.points[i];
    if (!p.allFinite()) continue;
    const TargetMatch m = target.nearestAnyClass(p, source.classes[i]);
    if (m.index < 0) continue;
    const auto j = static_cast<std::size_t>(m.index);
    const Eigen::Vector3f d = p - target.cloud().points[j];
    const float off = target.hasNormals() && target.normal(j).squaredNorm() > 0.5f ? std::abs(target.normal(j).dot(d))
                                                                                  : d.norm();
    on_surface += off <= tau;
  }
  return static_cast<double>(on_surface) / static_cast<double>(source.size());
}

namespace {

struct Start {
  Eigen::Isometry3d pose;  ///< W space
  std::string name;
  /// Only a probe: its answer can make the frame ambiguous but is never used (along a weak axis
  /// a better surface fit is no proof: corridor with wheel odometry, 19 frames wrong when used).
  bool probe = false;
};

struct Verified {
  RegistrationResult registration;
  std::string name;
  bool from_guess = false;
  double fit = 0.0;  ///< share of source points on a target surface (surfaceFit)
  bool probe = false;
  std::string label_note;  ///< the labels placed it along an axis (how)
  bool label_precise = false;
  Eigen::Vector3d label_axis = Eigen::Vector3d::Zero();
};

// Two answers that fit alike but lie apart along a line (a corridor) are not ambiguous when the
// labels decide along that line (labelsDecideAxes): `best` moves where they say. True when they did.
using LabelResolver = std::function<bool(Verified& best, const Verified& other)>;

// The local map (or previous scan) near the sensor: the global registration's target.
LabeledCloud nearbyTarget(const LabeledCloud& cloud, const Eigen::Vector3d& centre, double radius) {
  const Eigen::Vector3f c = centre.cast<float>();
  const float r2 = static_cast<float>(radius * radius);
  std::vector<std::size_t> keep;
  keep.reserve(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if ((cloud.points[i] - c).squaredNorm() <= r2) keep.push_back(i);
  return keep.size() == cloud.size() ? cloud : cloud.select(keep);
}

// An ICP's answer, its searches added to the frame's work.
RegistrationResult counted(RegistrationResult r, const OdometryConfig& config, OdometryFrame& f) {
  f.searches += icpSearches(r, config.registration);
  return r;
}

bool distinct(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return translationNorm(d) > kDistinctTranslation || rotationAngle(d) > kDistinctRotation;
}

std::string describeAmbiguity(const Verified& a, const Verified& b) {
  const Eigen::Isometry3d d = a.registration.transform.inverse() * b.registration.transform;
  char buf[256];
  std::snprintf(buf, sizeof buf, "ambiguous: %s (fit %.3f) and %s (fit %.3f) are %.2f m / %.1f deg apart",
                a.name.c_str(), a.fit, b.name.c_str(), b.fit, translationNorm(d),
                rotationAngle(d) * 180.0 / M_PI);
  return buf;
}

std::string describeNoGain(const Verified& v, double guess_fit) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s fits no better than the guess (%.3f vs %.3f on a surface)", v.name.c_str(), v.fit,
                guess_fit);
  return buf;
}

// The best fit wins; ICP from the guess gets kRecoveryMinGain ahead (it is what tracking
// trusts when nothing is wrong). A probe along a weak axis wins only when it fits better than
// that by kProbeGain (a slip along a corridor-like stretch the encoders lied about:
// naraha, ICP from the guess 0.55 on a surface, the probe 0.94). A distinct answer that fits as
// well as the winner makes the frame ambiguous. Returns verified.size() when nothing is used.
std::size_t pickAnswer(std::vector<Verified>& verified, std::string& outcome,
                       const std::string& rejected, const LabelResolver& resolve) {
  const auto rank = [&](const Verified& v) { return v.fit + (v.from_guess ? kRecoveryMinGain : 0.0); };
  std::size_t best = verified.size(), probe = verified.size();
  for (std::size_t i = 0; i < verified.size(); ++i) {
    std::size_t& slot = verified[i].probe ? probe : best;
    if (slot == verified.size() || rank(verified[i]) > rank(verified[slot])) slot = i;
  }
  if (probe != verified.size() &&
      (best == verified.size() || verified[probe].fit >= rank(verified[best]) + kProbeGain))
    best = probe;
  if (best == verified.size()) {
    outcome += (outcome.empty() ? "" : "; ") + std::string("only probes verified (") + rejected + ")";
    return best;
  }
  for (std::size_t i = 0; i < verified.size(); ++i)
    if (i != best && distinct(verified[i].registration.transform, verified[best].registration.transform) &&
        verified[i].fit >= verified[best].fit - kRecoveryAmbiguity) {
      if (resolve && resolve(verified[best], verified[i])) continue;
      outcome = describeAmbiguity(verified[best], verified[i]);
      return verified.size();
    }
  return best;
}

}  // namespace

namespace {

// Along an axis the geometry barely constrains (a corridor), ICP stays near where it starts:
// starts a step or two either way of the guess show whether another position fits as well.
void addWeakAxisProbes(std::vector<Start>& starts, const RegistrationResult& from_guess, const Eigen::Isometry3d& guess) {
  const auto axis = weakHorizontalAxis(from_guess, kSuspectWeakAxisRatio);
  if (!axis) return;
  for (const double k : {-2.0, -1.0, 1.0, 2.0}) {
    Eigen::Isometry3d s = guess;
    s.translation() += k * kAxisProbeStep * *axis;
    char name[64];
    std::snprintf(name, sizeof name, "guess %+.1f m along the weak axis", k * kAxisProbeStep);
    starts.push_back({s, name, /*probe=*/true});
  }
}

std::string probeAnswerAlongWeakestAxis(const LabeledCloud& source, const RegistrationTarget& target,
                                        const ClassTable& classes, const OdometryConfig& config,
                                        const OdometryConfig& seed_config, const Verified& answer) {
  return ambiguousAlongWeakestAxis(source, target, classes, config, seed_config, answer.registration, answer.fit,
                                   answer.name);
}

// The winner's place along its weakest horizontal axis: where the geometry doubts it (another
// position fits as well) the labels place it or it is refused; a winner the labels put clearly
// elsewhere is refused. False (`outcome` says why) when refused.
bool settleAlongWeakestAxis(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                            const ClassTable& classes, const OdometryConfig& config, const OdometryConfig& seed_config,
                            Verified& answer, std::string& outcome) {
  if (config.recovery.relocalise_suspect && !answer.from_guess && answer.label_note.empty()) {
    std::string doubt = probeAnswerAlongWeakestAxis(source, target, classes, config, seed_config, answer);
    if (!placeByLabels(view, source, target, classes, config, answer.registration, doubt, answer.label_note,
                       answer.label_precise, nullptr)) {
      outcome = std::move(doubt);
      return false;
    }
  }
  if (answer.label_note.empty() && labelsDecideAxes(config)) {
    const std::string contradiction = labelsContradict(view, source, target, classes, config, answer.registration);
    if (!contradiction.empty()) {
      outcome = answer.name + ": " + contradiction;
      return false;
    }
  }
  return true;
}

// `best` and `other` differ by a shift, not a turn: the labels decide along the horizontal line
// between them (once; a third answer along the same line is decided by then too).
bool resolveByLabels(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                     const ClassTable& classes, const OdometryConfig& config, Verified& best, const Verified& other) {
  const Eigen::Isometry3d d = best.registration.transform.inverse() * other.registration.transform;
  if (rotationAngle(d) > kDistinctRotation) return false;
  Eigen::Vector3d line = other.registration.transform.translation() - best.registration.transform.translation();
  line.z() = 0.0;
  if (line.norm() < 1e-6) return false;
  line.normalize();
  if (!best.label_note.empty()) return std::abs(line.dot(best.label_axis)) > 0.9;
  const LabelPlacement lp = placeAlongAxisByLabels(view, classes, best.registration.transform, line, config);
  if (!lp.decided) return false;
  if (!applyPlacementIfGeometryAllows(source, target, best.registration, line, lp)) return false;
  best.label_note = describe(lp);
  best.label_precise = lp.precise;
  best.label_axis = line;
  best.fit = surfaceFit(source, target, best.registration.transform, kSurfaceInlierDistance);
  return true;
}

}  // namespace

// A recovery answer can slide along a corridor as far as its seed was off (a "no motion" seed
// ends 1 m short and passes every check; corridor worst day: 13 of 99 frames silently wrong) even
// when the Hessian does not call the axis weak. ICP restarted a step or two either way along the
// answer's weakest horizontal axis shows whether another position fits as well: then the answer
// is ambiguous (empty when it is not).
std::string ambiguousAlongWeakestAxis(const LabeledCloud& source, const RegistrationTarget& target,
                                      const ClassTable& classes, const OdometryConfig& config,
                                      const OdometryConfig& seed_config, const RegistrationResult& answer, double fit,
                                      const std::string& answer_name) {
  const auto axis = weakHorizontalAxis(answer, 1.0);
  if (!axis) return {};
  const Eigen::Isometry3d& pose = answer.transform;
  for (const double k : {-2.0, -1.0, 1.0, 2.0}) {
    Eigen::Isometry3d s = pose;
    s.translation() += k * kAxisProbeStep * *axis;
    RegistrationResult r = registerClouds(source, target, s, classes, config.registration);
    if (!registrationFailure(r, s, seed_config).empty() || !distinct(r.transform, pose)) continue;
    const double other_fit = surfaceFit(source, target, r.transform, kSurfaceInlierDistance);
    if (other_fit < fit - kRecoveryAmbiguity) continue;
    char name[64];
    std::snprintf(name, sizeof name, "its answer %+.1f m along its weakest axis", k * kAxisProbeStep);
    return describeAmbiguity(Verified{answer, answer_name, false, fit, false, {}, false, {}},
                             Verified{std::move(r), name, false, other_fit, true, {}, false, {}});
  }
  return {};
}

void applyLabelPlacement(RegistrationResult& r, const Eigen::Vector3d& axis, const LabelPlacement& placement) {
  r.transform = shiftedAlong(r.transform, axis, placement.offset);
  const Eigen::Vector3d a = axis.normalized();
  r.covariance.topLeftCorner<3, 3>() += kLabelAxisSigma * kLabelAxisSigma * a * a.transpose();
}

bool applyPlacementIfGeometryAllows(const LabeledCloud& source, const RegistrationTarget& target, RegistrationResult& r,
                                    const Eigen::Vector3d& axis, const LabelPlacement& placement) {
  if (std::abs(placement.offset) <= kLabelAxisConfirm) return true;
  const double before = surfaceFit(source, target, r.transform, kSurfaceInlierDistance);
  const double after = surfaceFit(source, target, shiftedAlong(r.transform, axis, placement.offset),
                                  kSurfaceInlierDistance);
  if (after < before - kRecoveryAmbiguity) return false;
  applyLabelPlacement(r, axis, placement);
  return true;
}

std::string labelsContradict(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                             const ClassTable& classes, const OdometryConfig& config, const RegistrationResult& answer) {
  const std::optional<Eigen::Vector3d> axis = weakHorizontalAxis(answer, 1.0);
  if (!axis) return {};
  const LabelPlacement lp = placeAlongAxisByLabels(view, classes, answer.transform, *axis, config);
  if (!lp.decided || std::abs(lp.offset) <= kDistinctTranslation) return {};
  // Where the labels say, the scan must fit the geometry as well, or the labels are the wrong ones
  // (naraha frame 93: 27 of 36 labelled points agreed on a place 0.8 m off in a room).
  const double here = surfaceFit(source, target, answer.transform, kSurfaceInlierDistance);
  const double there = surfaceFit(source, target, shiftedAlong(answer.transform, *axis, lp.offset),
                                  kSurfaceInlierDistance);
  if (there < here - kRecoveryAmbiguity) return {};
  char buf[240];
  std::snprintf(buf, sizeof buf, "the labels put it %+.2f m along its weakest axis (%zu of %zu labelled points agree): flagged",
                lp.offset, lp.support, lp.labelled);
  return buf;
}

bool placeByLabels(const LabelView& view, const LabeledCloud& source, const RegistrationTarget& target,
                   const ClassTable& classes, const OdometryConfig& config, RegistrationResult& answer,
                   std::string& doubt, std::string& note, bool& precise, Eigen::Vector3d* placed_along) {
  std::optional<Eigen::Vector3d> axis = weakHorizontalAxis(answer, kFlagWeakAxisRatio);
  if (!axis && doubt.empty()) return true;
  if (!labelsDecideAxes(config)) return doubt.empty();
  if (!axis) axis = weakHorizontalAxis(answer, 1.0);
  if (!axis) return doubt.empty();
  const LabelPlacement lp = placeAlongAxisByLabels(view, classes, answer.transform, *axis, config);
  if (!lp.decided) {  // merely weak: used, and tracking flags the frame; doubted: refused
    if (!doubt.empty()) doubt += "; " + lp.why;
    return doubt.empty();
  }
  if (!applyPlacementIfGeometryAllows(source, target, answer, *axis, lp)) {  // as undecided
    if (!doubt.empty()) doubt += "; the labels' position fits the geometry worse";
    return doubt.empty();
  }
  note = describe(lp);
  precise = lp.precise;
  doubt.clear();
  if (placed_along) *placed_along = *axis;
  return true;
}


bool onlyVerticalDegeneracy(const std::vector<Vector6d>& directions) {
  for (const Vector6d& b : directions)
    if (std::hypot(b(0), b(1), b(5)) > 0.3 * b.norm()) return false;
  return true;
}

std::optional<Eigen::Vector3d> weakHorizontalAxis(const RegistrationResult& r, double ratio) {
  return weakHorizontalAxis(r.hessian, ratio);
}

std::optional<Eigen::Vector3d> weakHorizontalAxis(const Matrix6d& hessian, double ratio) {
  if (!(ratio > 0.0) || !hessian.allFinite() || hessian.isZero()) return std::nullopt;
  const Matrix6d H = 0.5 * (hessian + hessian.transpose());
  const Eigen::LDLT<Eigen::Matrix3d> rot(H.bottomRightCorner<3, 3>());
  if (rot.info() != Eigen::Success) return std::nullopt;
  // Translation information with the rotation free (Schur complement).
  const Eigen::Matrix3d S = H.topLeftCorner<3, 3>() - H.topRightCorner<3, 3>() * rot.solve(H.bottomLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (S + S.transpose()));
  const double strongest = es.eigenvalues()(2);
  if (!(strongest > 0.0)) return std::nullopt;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d v = es.eigenvectors().col(i);
    if (es.eigenvalues()(i) < ratio * strongest && std::abs(v.z()) < 0.5) return v;
  }
  return std::nullopt;
}

std::optional<Eigen::Isometry3d> Odometry::globalStart(OdometryFrame& f, const LabeledCloud& source,
                                                       const RegistrationTarget& target, const Eigen::Isometry3d& W) {
  const GlobalRegistrationConfig gc = globalConfigOf(config_);
  // Target points near the sensor; the viewpoint orients the target's normals.
  const Eigen::Vector3d viewpoint = (W.inverse() * frames_.back().pose).translation();
  const GlobalRegistrationTarget prepared = prepareGlobalTarget(
      nearbyTarget(target.cloud(), viewpoint, kRecoveryMapRadius), classes_, gc, viewpoint.cast<float>());
  const GlobalRegistrationResult g = registerGlobally(source, prepared, classes_, gc);
  f.global.tried = true;
  f.global.status = g.status;
  f.global.score = g.score;
  f.global.second_best_score = g.second_best_score;
  if (g.success && !g.ambiguous) return g.transform;
  // Unconstrained only in height / roll / pitch: the answer still places the robot on the ground
  // plane; it is a seed, and ICP from it is verified like any other.
  if (g.status == GlobalStatus::Degenerate && onlyVerticalDegeneracy(g.refinement.degenerate_directions)) {
    f.global.outcome = "global registration: vertically degenerate, used as a seed";
    return g.transform;
  }
  f.global.outcome = "global registration: " + (g.reason.empty() ? std::string(toString(g.status)) : g.reason);
  return std::nullopt;
}

std::optional<Odometry::Recovery> Odometry::recover(OdometryFrame& f, const LabeledCloud& source,
                                                    const RegistrationTarget& target, const Eigen::Isometry3d& W,
                                                    const RegistrationResult& from_guess, bool guess_passed,
                                                    bool probes_only) {
  const auto t = Clock::now();
  const Eigen::Isometry3d prev = W.inverse() * frames_.back().pose;  // previous frame in W space
  std::vector<Start> starts;
  if (!probes_only) {
    if (auto g = globalStart(f, source, target, W)) starts.push_back({*g, "global registration"});
    starts.push_back({prev, "no motion"});
    for (const double deg : {-45.0, -30.0, -15.0, 15.0, 30.0, 45.0})  // a yaw kick the encoders missed
      starts.push_back({prev * f.guess * Eigen::AngleAxisd(deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()),
                        "guess turned " + std::to_string(int(deg)) + " deg"});
    if (f.wheel_guess && frames_.size() >= 2) starts.push_back({prev * frames_.back().increment, "constant velocity"});
  }
  if (config_.recovery.relocalise_suspect) addWeakAxisProbes(starts, from_guess, prev * f.guess);

  std::vector<Verified> verified;
  std::string rejected;
  const OdometryConfig seed_config = seedConfigOf(config_);
  const auto check = [&](RegistrationResult r, const Eigen::Isometry3d& start, const std::string& name, bool guess,
                         bool probe) {
    // A start other than the guess is only a seed: ICP may travel farther from it (up to
    // kStartCorrectionTranslation) — surface fit, RMSE, plausibility and ambiguity judge the answer.
    std::string why = registrationFailure(r, start, guess ? config_ : seed_config);
    const Eigen::Isometry3d increment = prev.inverse() * r.transform;
    char buf[96];
    if (why.empty() && !guess && !onlyVerticalDegeneracy(r.degenerate_directions)) {
      // Along an unconstrained direction ICP stays where it started: the answer says nothing
      // there, and tracking keeps the guess along it (tanks seed 3: "no motion" won this way).
      std::snprintf(buf, sizeof buf, "degenerate (%zu unconstrained direction(s))", r.degenerate_directions.size());
      why = buf;
    } else if (why.empty() && fitsWorseThanTracked(r, impl_->typical_rmse)) {
      std::snprintf(buf, sizeof buf, "inlier RMSE %.3f m", r.inlier_rmse);
      why = buf;
    } else if (why.empty() && (translationNorm(increment) > config_.recovery.max_translation ||
                               rotationAngle(increment) > config_.recovery.max_rotation)) {
      std::snprintf(buf, sizeof buf, "implausible motion %.2f m / %.1f deg", translationNorm(increment),
                    rotationAngle(increment) * 180.0 / M_PI);
      why = buf;
    }
    if (why.empty()) {
      const double fit = surfaceFit(source, target, r.transform, kSurfaceInlierDistance);
      verified.push_back({std::move(r), name, guess, fit, probe, {}, false, Eigen::Vector3d::Zero()});
    }
    else rejected += (rejected.empty() ? "" : "; ") + name + ": " + why;
  };
  const Eigen::Isometry3d guess = prev * f.guess;
  if (guess_passed) check(from_guess, guess, "ICP from the guess", true, false);
  // Failed, ICP from the guess is still a seed's answer like the others (a 2 m step guessed as 1 m
  // ends 1.0003 m from the guess: beyond the tracking limit, well within a seed's; naraha s1).
  else check(from_guess, guess, "ICP from the guess as a seed", false, false);
  for (const Start& s : starts)
    check(counted(registerClouds(source, target, s.pose, classes_, config_.registration), config_, f), s.pose, s.name,
          false, s.probe);
  f.global.milliseconds = msSince(t);
  if (verified.empty()) {
    f.global.outcome += (f.global.outcome.empty() ? "" : "; ") + std::string("nothing verified (") + rejected + ")";
    return std::nullopt;
  }
  const LabelResolver resolve = [&](Verified& best, const Verified& other) {
    return labelsDecideAxes(config_) && resolveByLabels(impl_->labelView(), source, target, classes_, config_, best, other);
  };
  const std::size_t best = pickAnswer(verified, f.global.outcome, rejected, resolve);
  if (best == verified.size()) return std::nullopt;
  // When ICP from the guess failed, the frame falls back to the guess itself: an answer must fit
  // clearly better than that pose does, or tracking keeps the guess (and flags the frame).
  if (!verified[best].from_guess && !guess_passed) {
    const double guess_fit = surfaceFit(source, target, guess, kSurfaceInlierDistance);
    if (verified[best].fit < guess_fit + kRecoveryMinGain) {
      f.global.outcome = describeNoGain(verified[best], guess_fit);
      return std::nullopt;
    }
  }
  if (!settleAlongWeakestAxis(impl_->labelView(), source, target, classes_, config_, seed_config, verified[best],
                              f.global.outcome))
    return std::nullopt;
  const std::string& label_note = verified[best].label_note;
  f.global.outcome = "used " + verified[best].name + (label_note.empty() ? "" : "; " + label_note);
  impl_->label_note = label_note;
  impl_->label_precise = verified[best].label_precise;
  return Recovery{std::move(verified[best].registration), verified[best].from_guess};
}

}  // namespace hazmap
