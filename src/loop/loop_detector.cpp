#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/core/yield_point.hpp"
#include "hazmap/loop/loop_closure.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"

#include <algorithm>
#include <limits>
#include <optional>

namespace hazmap {

LoopDetector::LoopDetector(ClassTable classes, LoopClosureConfig config)
    : classes_(std::move(classes)), config_(std::move(config)), consistency_(config_.consistency) {
  config_.validate();
  for (ClassId id : classes_.ids())
    neighbourhood_ = neighbourhood_ || (classes_.isProperty(id) && !classes_.at(id).whole_extent);
  neighbourhood_ = neighbourhood_ && config_.partial_landmark_window > 0;
}

LabeledCloud LoopDetector::prepare(LabeledCloud cloud) const {
  if (config_.keyframe_voxel > 0.0) cloud = voxelDownsample(cloud, propertyVoxels(config_.keyframe_voxel), classes_);
  return cloud;
}

std::size_t LoopDetector::addKeyframe(LabeledCloud cloud) {
  cloud.checkConsistent("loop closure keyframe " + std::to_string(clouds_.size()));
  landmarks_.push_back(extractLandmarks(cloud, classes_, config_.landmarks));
  if (neighbourhood_) {
    auto& whole = whole_landmarks_.emplace_back();
    auto& partial = partial_landmarks_.emplace_back();
    for (const PropertyLandmark& l : landmarks_.back()) (classes_.at(l.class_id).whole_extent ? whole : partial).push_back(l);
  }
  clouds_.push_back(std::make_shared<const LabeledCloud>(prepare(std::move(cloud))));
  // Bound memory: only the newest keyframes stay resident when they can be reloaded.
  if (loader_ && clouds_.size() > config_.resident_keyframes)
    clouds_[clouds_.size() - 1 - config_.resident_keyframes].reset();
  return clouds_.size() - 1;
}

std::shared_ptr<const LabeledCloud> LoopDetector::cloud(std::size_t k) const {
  if (k >= clouds_.size()) fail("loop closure", "keyframe " + std::to_string(k) + " does not exist");
  if (clouds_[k]) return clouds_[k];
  // Reloaded clouds: the last few stay cached, since a submap and the next queries (the robot
  // moves on along the old path) need the same old keyframes again.
  for (const auto& [index, c] : reloaded_)
    if (index == k) return c;
  LabeledCloud raw = loader_(k);
  raw.checkConsistent("loop closure keyframe " + std::to_string(k) + " (reloaded)");
  auto c = std::make_shared<const LabeledCloud>(prepare(std::move(raw)));
  reloaded_.emplace_back(k, c);
  if (reloaded_.size() > kReloadCache) reloaded_.pop_front();
  return c;
}

LabeledCloud LoopDetector::submap(std::size_t k, std::size_t query, const PoseList& estimate) const {
  if (k >= size()) fail("loop closure", "keyframe " + std::to_string(k) + " does not exist");
  const std::size_t w = config_.submap_keyframes;
  if (w == 0) return *cloud(k);
  if (estimate.size() < size()) fail("loop closure", "a submap needs a pose estimate for every keyframe");
  const std::size_t gap = config_.candidates.min_index_gap;
  const std::size_t last = std::min(k + w, query >= gap ? query - gap : k);
  LabeledCloud merged = *cloud(k);
  for (std::size_t j = k >= w ? k - w : 0; j <= last; ++j) {
    yieldPoint();
    if (j != k) merged.append(cloud(j)->transformed(estimate[k].inverse() * estimate[j]));
  }
  yieldPoint();
  return prepare(std::move(merged));
}

std::shared_ptr<const RegistrationTarget> LoopDetector::submapTarget(std::size_t k, std::size_t query,
                                                                     const PoseList& estimate) const {
  if (k >= size()) fail("loop closure", "keyframe " + std::to_string(k) + " does not exist");
  const std::size_t w = config_.submap_keyframes, gap = config_.candidates.min_index_gap;
  CachedSubmap key;
  key.k = k;
  key.first = w > 0 && k >= w ? k - w : k;
  key.last = w > 0 ? std::min(k + w, query >= gap ? query - gap : k) : k;
  if (w > 0) {
    if (estimate.size() < size()) fail("loop closure", "a submap needs a pose estimate for every keyframe");
    for (std::size_t j = key.first; j <= key.last; ++j) key.placement.push_back(estimate[k].inverse() * estimate[j]);
  }
  // The same keyframes placed identically give the same target, bit for bit; with
  // submap_reuse_tolerance also placed within that of where the cached target put them.
  const double tol = config_.submap_reuse_tolerance;
  const auto same = [tol](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    if (tol <= 0.0) return a.matrix() == b.matrix();
    return poseChangeSize(a.inverse() * b) <= tol;
  };
  for (const auto& c : submaps_)
    if (c.k == key.k && c.first == key.first && c.last == key.last &&
        std::equal(c.placement.begin(), c.placement.end(), key.placement.begin(), key.placement.end(), same))
      return c.target;
  key.target = std::make_shared<const RegistrationTarget>(submap(k, query, estimate), classes_,
                                                          config_.verification.icp());
  ++submap_targets_built_;
  std::erase_if(submaps_, [&](const CachedSubmap& c) { return c.k == k; });
  submaps_.push_back(std::move(key));
  if (submaps_.size() > kSubmapCache) submaps_.pop_front();
  return submaps_.back().target;
}

std::size_t LoopDetector::residentClouds() const {
  std::size_t n = 0;
  for (const auto& c : clouds_) n += c != nullptr;
  return n;
}

std::vector<LoopCandidate> LoopDetector::constellationCandidates(std::size_t query, std::size_t newest,
                                                                 const PoseList& estimate) const {
  if (config_.landmark_window <= 1 && !neighbourhood_)
    return findConstellationCandidates(query, landmarks_, config_.candidates);
  if (estimate.size() <= newest)
    fail("loop closure", "landmark windows need a pose estimate for keyframe " + std::to_string(newest));
  // A past keyframe's neighbourhood stops where the query's recent keyframes begin.
  const std::size_t gap = config_.candidates.min_index_gap;
  std::vector<std::vector<PropertyLandmark>> places(query + 1);
  places[query] = placeLandmarks(query, newest, estimate);
  for (std::size_t j = 0; j + gap <= query; ++j) places[j] = placeLandmarks(j, query - gap, estimate);
  std::vector<LoopCandidate> found = findConstellationCandidates(query, places, config_.candidates);
  return neighbourhood_ && config_.partial_nearest_keyframe ? nearestInStretch(std::move(found), estimate) : found;
}

// A neighbourhood constellation describes a stretch of keyframes, so the keyframe it names is any
// of them, often one 9–13 m from the query; registered from there the loop rests on the far,
// sparse rings of both scans and comes out biased (naraha camera labels, frame to local map:
// +2.5 to +6 cm in z, 4–8 mrad pitch, at NEES 7–14). Each candidate is verified instead at the
// stretch's keyframe nearest the query under the candidate's own guess (placed with the locally
// accurate estimate) that no better-ranked candidate of this query took, so the candidates try
// the query's nearest keyframes in turn.
std::vector<LoopCandidate> LoopDetector::nearestInStretch(std::vector<LoopCandidate> cands, const PoseList& estimate) const {
  // Both constellations span ±partial_landmark_window keyframes, so the landmarks they share put
  // the query within twice that of the named keyframe along the old path.
  const std::size_t p = 2 * config_.partial_landmark_window, gap = config_.candidates.min_index_gap;
  std::vector<LoopCandidate> out;
  for (const LoopCandidate& named : cands) {
    const std::size_t m = named.match, last = std::min(m + p, named.query - gap);
    const Eigen::Isometry3d T_world_query = estimate[m] * named.initial_guess;
    std::optional<LoopCandidate> best;
    for (std::size_t j = m >= p ? m - p : 0; j <= last; ++j) {
      if (std::any_of(out.begin(), out.end(), [&](const LoopCandidate& o) { return o.match == j; })) continue;
      const Eigen::Isometry3d T_j_query = estimate[j].inverse() * T_world_query;
      if (best && translationNorm(T_j_query) >= translationNorm(best->initial_guess)) continue;
      best = named;
      best->match = j;
      best->initial_guess = T_j_query;
    }
    if (best) out.push_back(*best);
  }
  return out;
}

// Camera labels leave many keyframes with too few landmarks for a constellation (a forward
// camera labels a source only while it lies ahead); there the labels cannot propose a loop, so
// the estimate does (partial_distance_below_landmarks).
bool LoopDetector::wantsDistanceCandidates(std::size_t query, const PoseList& estimate) const {
  if (config_.method != CandidateMethod::Constellation) return true;
  const std::size_t below = config_.partial_distance_below_landmarks;
  return neighbourhood_ && below > 0 && placeLandmarks(query, query, estimate).size() < below;
}

std::vector<LoopCandidate> LoopDetector::candidates(std::size_t query, const PoseList& estimate) const {
  if (query >= size()) fail("loop closure", "query keyframe " + std::to_string(query) + " does not exist");
  std::vector<LoopCandidate> out;
  if (config_.method != CandidateMethod::Distance) out = constellationCandidates(query, query, estimate);
  if (wantsDistanceCandidates(query, estimate)) {
    if (estimate.size() <= query)
      fail("loop closure", "the distance search needs a pose estimate for keyframe " + std::to_string(query));
    auto d = findDistanceCandidates(query, estimate, config_.candidates);
    // Both: constellation candidates first (they carry a landmark-derived guess), then distance
    // candidates for keyframes not already proposed.
    for (const auto& c : d) {
      bool seen = false;
      for (const auto& o : out) seen = seen || o.match == c.match;
      if (!seen) out.push_back(c);
    }
  }
  return out;
}

std::vector<PropertyLandmark> LoopDetector::placeLandmarks(std::size_t k, const PoseList& estimate) const {
  return placeLandmarks(k, size() - 1, estimate);
}

// Whole-extent classes: the keyframe and the landmark_window − 1 before it. Partial classes
// (camera labels): partial_landmark_window keyframes on each side, up to `newest`.
std::vector<PropertyLandmark> LoopDetector::placeLandmarks(std::size_t k, std::size_t newest,
                                                           const PoseList& estimate) const {
  if (k >= size() || newest < k) fail("loop closure", "keyframe " + std::to_string(k) + " does not exist");
  const std::size_t w = config_.landmark_window;
  const std::size_t first = k + 1 >= w ? k + 1 - w : 0;
  if (!neighbourhood_) {
    if (w <= 1) return landmarks_[k];
    return mergeLandmarks(landmarks_, estimate, first, k, k, config_.landmark_merge_distance);
  }
  std::vector<PropertyLandmark> out =
      w <= 1 ? whole_landmarks_[k] : mergeLandmarks(whole_landmarks_, estimate, first, k, k, config_.landmark_merge_distance);
  const std::size_t p = config_.partial_landmark_window;
  const std::size_t last = std::min({k + p, newest, size() - 1});
  const auto partial = mergeLandmarks(partial_landmarks_, estimate, k >= p ? k - p : 0, last, k, config_.landmark_merge_distance);
  // Only what lies within the landmarks' range of the keyframe, as its own scan would hold it:
  // a neighbour's view reaches farther, and a constellation should describe this place.
  const double range = config_.landmarks.max_range;
  for (const PropertyLandmark& l : partial)
    if (range <= 0.0 || l.centroid.norm() <= range) out.push_back(l);
  std::stable_sort(out.begin(), out.end(), [](const PropertyLandmark& a, const PropertyLandmark& b) {
    return a.class_id < b.class_id;
  });
  return out;
}

LoopDetection LoopDetector::detect(std::size_t query, const PoseList& estimate) {
  LoopDetection det;
  det.candidates = candidates(query, estimate);
  if (estimate.size() <= query)
    fail("loop closure", "the drift gate needs a pose estimate for keyframe " + std::to_string(query));
  verifyInto(det.candidates, estimate, det);
  // Neighbourhood landmarks: the keyframe partial_landmark_window back now has its keyframes
  // ahead too, the views of what it passed; search it again with them.
  const std::size_t p = config_.partial_landmark_window;
  if (!neighbourhood_ || config_.method == CandidateMethod::Distance || query < p) return det;
  std::vector<LoopCandidate> again = constellationCandidates(query - p, query, estimate);
  std::erase_if(again, [&](const LoopCandidate& c) {
    return std::any_of(loops_.begin(), loops_.end(), [&](const LoopClosure& l) { return l.from == c.match && l.to == c.query; });
  });
  LoopDetection delayed;
  verifyInto(again, estimate, delayed);
  det.candidates.insert(det.candidates.end(), again.begin(), again.end());
  det.verifications.insert(det.verifications.end(), delayed.verifications.begin(), delayed.verifications.end());
  det.gates.insert(det.gates.end(), delayed.gates.begin(), delayed.gates.end());
  det.accepted.insert(det.accepted.end(), delayed.accepted.begin(), delayed.accepted.end());
  det.light_verifications += delayed.light_verifications;
  return det;
}

LabeledCloud LoopDetector::querySubmap(std::size_t query, const PoseList& estimate) const {
  if (query >= size()) fail("loop closure", "keyframe " + std::to_string(query) + " does not exist");
  const std::size_t w = config_.cross_check_query_keyframes;
  if (w == 0) return *cloud(query);
  if (estimate.size() <= query) fail("loop closure", "a query submap needs a pose estimate for keyframe " + std::to_string(query));
  LabeledCloud merged = *cloud(query);
  for (std::size_t j = query >= w ? query - w : 0; j < query; ++j)
    merged.append(cloud(j)->transformed(estimate[query].inverse() * estimate[j]));
  return prepare(std::move(merged));
}

// The misfit term's cross-check (VerificationConfig::cross_check_chi2): the match side registered
// onto the query side from the inverse guess — the match submap onto the query keyframe's own
// neighbourhood (cross_check_query_keyframes), so the reverse answer rests on scans the forward
// one did not use. A loop whose two answers agree keeps its full information (the misfit term
// comes off again).
double LoopDetector::crossCheckDistance(const LoopCandidate& cand, const PoseList& estimate,
                                        const Eigen::Isometry3d& T_from_to, const Matrix6d& forward_covariance) const {
  const VerificationConfig& c = config_.verification;
  const bool submaps = config_.cross_check_query_keyframes > 0;
  const LabeledCloud query = submaps ? querySubmap(cand.query, estimate) : *cloud(cand.query);
  // The match submap is the forward registration's (cached) target: its points, not a rebuild.
  const auto match_target = submaps ? submapTarget(cand.match, cand.query, estimate) : nullptr;
  const auto match_scan = submaps ? nullptr : cloud(cand.match);
  const LabeledCloud& match = submaps ? match_target->cloud() : *match_scan;
  if (query.empty() || match.empty()) return std::numeric_limits<double>::quiet_NaN();
  const RegistrationTarget target(query, classes_, c.icp());
  RegistrationConfig reverse = c.icp();
  if (c.probe_coarse_points > 0) reverse.coarse_source_points = c.probe_coarse_points;
  const RegistrationResult rev = registerClouds(match, target, cand.initial_guess.inverse(), classes_, reverse);
  if (!rev.converged || !isFinite(rev.transform)) return std::numeric_limits<double>::quiet_NaN();
  const Vector6d d = se3Log(rev.transform.inverse() * T_from_to.inverse());
  Matrix6d sigma = 2.0 * c.covariance_scale * 0.5 * (forward_covariance + forward_covariance.transpose());
  sigma += floorVariances().asDiagonal();
  return d.dot(sigma.llt().solve(d));
}

namespace {
// How many keyframes apart a and b are (light-verification neighbourhoods).
std::size_t keyframeGap(std::size_t a, std::size_t b) { return a > b ? a - b : b - a; }
// A loop whose reverse cross-check agreed (its own, or a checked neighbour's for a light loop)
// no longer carries the misfit term (verification.hpp misfitTerm).
void dropMisfitTerm(VerificationResult& v, const VerificationConfig& c) {
  setLoopCovariance(v.closure, v.closure.covariance - misfitTerm(v.registration, c));
}
}  // namespace

bool LoopDetector::crossCheck(const LoopCandidate& cand, const PoseList& estimate, VerificationResult& v) const {
  const VerificationConfig& c = config_.verification;
  if (!(c.cross_check_chi2 > 0.0) || !(c.misfit_scale > 0.0)) return false;
  // Along a label-only direction both answers sit where the same labelled patches put them, so
  // their agreement is no evidence there (corridor 4: 46→78, 90 cm off, agreed to d² = 0.15).
  if (!v.registration.label_only_directions.empty()) return false;
  const double d2 = crossCheckDistance(cand, estimate, v.closure.T_from_to, v.registration.covariance);
  if (!(d2 <= c.cross_check_chi2)) return false;
  dropMisfitTerm(v, c);
  return true;
}

const LoopDetector::CheckedLoop* LoopDetector::checkedNeighbour(const LoopCandidate& cand) const {
  const std::size_t r = config_.light_duplicate_keyframes;
  if (r == 0) return nullptr;
  const CheckedLoop* best = nullptr;
  std::size_t best_gap = r + 1;
  for (const CheckedLoop& l : checked_) {
    const std::size_t g = std::max(keyframeGap(l.from, cand.match), keyframeGap(l.to, cand.query));
    if (g < best_gap) best = &l, best_gap = g;
  }
  return best;
}

Matrix6d LoopDetector::shortPathCovariance(std::size_t a, std::size_t b, const PoseList& estimate) const {
  if (a == b) return Matrix6d::Zero();
  if (relative_covariance_) return relative_covariance_(a, b);
  return driftCovariance(pathLength(estimate, a, b), config_.consistency);
}

// The candidate's loop against the reference's: from ← ref.from (estimate), the reference loop,
// ref.to ← to (estimate); all three covariances carried into `from`'s frame (left perturbations).
double LoopDetector::duplicateDistance2(const LoopClosure& loop, const LoopClosure& ref, const PoseList& estimate) const {
  const Eigen::Isometry3d A = estimate[loop.from].inverse() * estimate[ref.from];
  const Eigen::Isometry3d C = estimate[ref.to].inverse() * estimate[loop.to];
  const Eigen::Isometry3d AB = A * ref.T_from_to;
  const Vector6d e = se3Log(loop.T_from_to * (AB * C).inverse());
  const Matrix6d AdA = adjoint(A), AdAB = adjoint(AB);
  const Matrix6d sigma = loop.covariance + shortPathCovariance(loop.from, ref.from, estimate) +
                         AdA * ref.covariance * AdA.transpose() +
                         AdAB * shortPathCovariance(ref.to, loop.to, estimate) * AdAB.transpose();
  return e.dot((0.5 * (sigma + sigma.transpose())).llt().solve(e));
}

// Full checks: the verification ICP, the basin probes, the reverse cross-check. Light
// (light_duplicate_keyframes): when a fully checked loop ties the same two places and this answer
// agrees with it, the reverse cross-check is not run again and its verdict is taken over. The
// probes always run: along a revisit some near-duplicates of a sound loop are ambiguous
// themselves (naraha 2: 12→152 next to 12→151; tanks: each rejection only the ±y pair made).
VerificationResult LoopDetector::verifyOne(const LoopCandidate& cand, const PoseList& estimate, bool& light,
                                           CheckedLoop& checked) {
  const auto target = submapTarget(cand.match, cand.query, estimate);
  VerificationResult v = verifyCandidate(cand, *cloud(cand.query), *target, classes_, config_.verification);
  light = false;
  if (!v.accepted) return v;
  if (const CheckedLoop* ref = checkedNeighbour(cand)) {
    const auto same = std::find_if(loops_.begin(), loops_.end(), [&](const LoopClosure& l) { return l.from == ref->from && l.to == ref->to; });
    const double threshold = chiSquareQuantile(6, config_.consistency.gate_probability);
    if (same != loops_.end() && duplicateDistance2(v.closure, *same, estimate) <= threshold) {
      if (ref->cross_check_agreed && v.registration.label_only_directions.empty())
        dropMisfitTerm(v, config_.verification);
      light = true;
      return v;
    }
  }
  checked.from = cand.match;
  checked.to = cand.query;
  checked.cross_check_agreed = crossCheck(cand, estimate, v);
  return v;
}

void LoopDetector::verifyInto(const std::vector<LoopCandidate>& candidates, const PoseList& estimate, LoopDetection& det) {
  for (const auto& cand : candidates) {
    yieldPoint();
    if (det.accepted.size() >= config_.max_loops_per_keyframe) break;
    if (relative_covariance_ && !candidatePlausible(cand, estimate, det)) continue;
    bool light = false;
    CheckedLoop checked;
    VerificationResult v = verifyOne(cand, estimate, light, checked);
    det.verifications.push_back(v);
    if (!v.accepted) continue;
    // Every verified loop is gated against the estimate: the innovation gate when the back end
    // gives the graph's covariance, else the drift model's.
    const bool innovation = static_cast<bool>(relative_covariance_);
    const GateResult g = innovation ? innovationGate(v.closure, estimate, relative_covariance_(v.closure.from, v.closure.to),
                                                     config_.consistency.gate_probability)
                                    : driftGate(v.closure, estimate, config_.consistency);
    det.gates.push_back(g);
    if (!g.accepted) {
      det.verifications.back().accepted = false;
      det.verifications.back().rejection = innovation ? LoopRejection::InnovationGate : LoopRejection::DriftGate;
      det.verifications.back().reason = std::string(innovation ? "innovation" : "drift") + " gate: d² = " +
                                        std::to_string(g.mahalanobis2) + " > " + std::to_string(g.threshold);
      continue;
    }
    det.accepted.push_back(v.closure);
    loops_.push_back(v.closure);
    if (light) ++det.light_verifications;
    else checked_.push_back(checked);
  }
}

std::vector<LoopClosure> LoopDetector::consistentLoops(const PoseList& estimate) const {
  std::vector<LoopClosure> out;
  for (std::size_t i : consistency_.subset(loops_, estimate)) out.push_back(loops_[i]);
  return out;
}

// The innovation gate on the candidate's guess, before any ICP: the landmark constellation's guess
// (σ = inlier_distance in x, y, z; its yaw error is bounded by the distance tolerance over the
// pair baseline, taken as inlier_distance / min_pair_distance) against the graph's relative pose.
// A candidate the tracking makes impossible costs no registration.
bool LoopDetector::candidatePlausible(const LoopCandidate& cand, const PoseList& estimate, LoopDetection& det) const {
  LoopClosure guess;
  guess.from = cand.match;
  guess.to = cand.query;
  guess.T_from_to = cand.initial_guess;
  const double st = config_.candidates.constellation.inlier_distance;
  const double sr = st / kConstellationMinPairDistance;
  guess.covariance = (Vector6d() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr).finished().asDiagonal();
  const GateResult g = innovationGate(guess, estimate, relative_covariance_(cand.match, cand.query),
                                      config_.consistency.gate_probability);
  if (g.accepted) return true;
  VerificationResult v;
  v.closure = guess;
  v.rejection = LoopRejection::InnovationGate;
  v.reason = "candidate guess, innovation gate: d² = " + std::to_string(g.mahalanobis2) + " > " + std::to_string(g.threshold);
  det.verifications.push_back(std::move(v));
  return false;
}

void LoopDetector::dropLoop(std::size_t from, std::size_t to) {
  std::erase_if(loops_, [&](const LoopClosure& l) { return l.from == from && l.to == to; });
  std::erase_if(checked_, [&](const CheckedLoop& l) { return l.from == from && l.to == to; });
}

bool isTrueLoop(const LoopClosure& loop, const PoseList& truth, double max_t, double max_r) {
  if (loop.from >= truth.size() || loop.to >= truth.size())
    fail("isTrueLoop", "loop keyframe index out of range of the ground truth");
  const Eigen::Isometry3d err = (truth[loop.from].inverse() * truth[loop.to]).inverse() * loop.T_from_to;
  return translationNorm(err) <= max_t && rotationAngle(err) <= max_r;
}

}  // namespace hazmap
