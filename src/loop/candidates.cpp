#include "hazmap/loop/candidates.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/core/stable_sort.hpp"

namespace hazmap {

// Internal gates and ranking of constellation matching (issue 37: named constants, not keys;
// their old keys name this file).
/// m; two landmark pairs are compatible when their centroid distances differ by at most this: centroids of partly seen clusters move by a fraction of the cluster size between views.
constexpr double kDistanceTolerance = 0.8;
/// m; triples whose smallest triangle height is below this are collinear for the full-3d model.
constexpr double kMinTriangleHeight = 1.0;
/// Descriptor gate: largest principal extent ratio. Loose, because a source seen from another side or distance is only partly covered by the scan rings.
constexpr double kMaxExtentRatio = 4.0;
/// Exhaustive search over compatible pairs (triples) up to this many hypotheses, a seeded random sample beyond: bounded time on repeated classes.
constexpr std::size_t kMaxHypotheses = 4000;
/// m; negative evidence: an unmatched landmark this close to the other keyframe's sensor should have been seen there (the landmarks' default max_range).
constexpr double kVisibilityRange = 15.0;
/// Hypotheses are ranked by inliers − this · misses: a miss is weaker evidence than a match.
constexpr double kMissPenalty = 0.5;
/// A match needs 2·inliers / (2·inliers + misses) >= this: chance alignments of a few same-class sources leave many landmarks unexplained.
constexpr double kMinOverlap = 0.7;

const char* toString(CandidateSource source) {
  return source == CandidateSource::Constellation ? "constellation" : "distance";
}

namespace {

using Corr = std::pair<std::size_t, std::size_t>;  // (query landmark, match landmark)

bool compatible(const PropertyLandmark& a, const PropertyLandmark& b, const ConstellationConfig& c) {
  if (a.class_id != b.class_id) return false;
  const double ea = std::max(a.extent(0), 0.05), eb = std::max(b.extent(0), 0.05);
  if (std::max(ea, eb) / std::min(ea, eb) > kMaxExtentRatio) return false;
  if (c.property_value_tolerance > 0.0 && a.has_property_value && b.has_property_value &&
      std::abs(a.mean_property - b.mean_property) > c.property_value_tolerance)
    return false;
  return true;
}

// Least-squares rigid transform m ≈ T q over the given correspondences.
Eigen::Isometry3d fitTransform(const std::vector<Eigen::Vector3d>& q,
                               const std::vector<Eigen::Vector3d>& m, ConstellationModel model) {
  const double n = static_cast<double>(q.size());
  Eigen::Vector3d qc = Eigen::Vector3d::Zero(), mc = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < q.size(); ++i) {
    qc += q[i];
    mc += m[i];
  }
  qc /= n;
  mc /= n;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < q.size(); ++i) H += (q[i] - qc) * (m[i] - mc).transpose();
  Eigen::Matrix3d R;
  if (model == ConstellationModel::Planar) {
    // argmax_θ Σ m'ᵀ R(θ) q' over the xy components.
    const double yaw = std::atan2(H(0, 1) - H(1, 0), H(0, 0) + H(1, 1));
    R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  } else {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
    D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
    R = svd.matrixV() * D * svd.matrixU().transpose();
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = mc - R * qc;
  return T;
}

struct Scored {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  std::vector<Corr> inliers;
  double rmse = 0.0;
  std::size_t misses = 0;  // landmarks the other keyframe should have seen but did not
  double value = 0.0;      // inliers − miss_penalty · misses
  bool better(const Scored& o) const {
    if (value != o.value) return value > o.value;
    if (inliers.size() != o.inliers.size()) return inliers.size() > o.inliers.size();
    return rmse < o.rmse;
  }
};

// The facing direction of a flat, upright landmark (a heat panel on a wall): the normal of its
// PCA plane, turned toward the sensor that saw it. nullopt for floor patches, blobs and lines,
// whose orientation says nothing about yaw.
std::optional<Eigen::Vector3d> facing(const PropertyLandmark& l) {
  if (l.extent(1) < 0.05 || !(l.extent(2) < 0.3 * l.extent(1))) return std::nullopt;
  Eigen::Vector3d n = l.axes.col(2);
  if (std::abs(n.z()) > 0.7) return std::nullopt;
  if (n.dot(-l.centroid) < 0) n = -n;
  return n;
}

// One-to-one inlier assignment: greedy by residual over all compatible correspondences.
Scored score(const Eigen::Isometry3d& T, const std::vector<Corr>& corrs,
             const std::vector<PropertyLandmark>& q, const std::vector<PropertyLandmark>& m,
             const ConstellationConfig& c) {
  std::vector<std::pair<double, std::size_t>> close;
  const double cos_tol = std::cos(c.facing_tolerance);
  for (std::size_t k = 0; k < corrs.size(); ++k) {
    const PropertyLandmark& a = q[corrs[k].first];
    const PropertyLandmark& b = m[corrs[k].second];
    const double r = (T * a.centroid - b.centroid).norm();
    if (r > c.inlier_distance) continue;
    // A panel seen from its front in one keyframe cannot face away in the other: this breaks
    // the 180° ambiguity of two same-class sources.
    if (c.facing_tolerance > 0.0) {
      const auto na = facing(a), nb = facing(b);
      if (na && nb && (T.linear() * *na).dot(*nb) < cos_tol) continue;
    }
    close.emplace_back(r, k);
  }
  std::sort(close.begin(), close.end());
  std::vector<char> used_q(q.size(), 0), used_m(m.size(), 0);
  Scored s;
  s.T = T;
  double sq = 0.0;
  for (const auto& [r, k] : close) {
    const auto [i, j] = corrs[k];
    if (used_q[i] || used_m[j]) continue;
    used_q[i] = used_m[j] = 1;
    s.inliers.push_back(corrs[k]);
    sq += r * r;
  }
  s.rmse = s.inliers.empty() ? 0.0 : std::sqrt(sq / static_cast<double>(s.inliers.size()));
  // Negative evidence: an unmatched landmark that the hypothesis puts within the other
  // keyframe's sensing range should have been seen there.
  if (kVisibilityRange > 0.0) {
    const Eigen::Isometry3d Ti = T.inverse();
    for (std::size_t i = 0; i < q.size(); ++i)
      if (!used_q[i] && (T * q[i].centroid).norm() <= kVisibilityRange) ++s.misses;
    for (std::size_t j = 0; j < m.size(); ++j)
      if (!used_m[j] && (Ti * m[j].centroid).norm() <= kVisibilityRange) ++s.misses;
  }
  s.value = static_cast<double>(s.inliers.size()) - kMissPenalty * static_cast<double>(s.misses);
  return s;
}

Scored refine(Scored s, const std::vector<Corr>& corrs, const std::vector<PropertyLandmark>& q,
              const std::vector<PropertyLandmark>& m, const ConstellationConfig& c) {
  auto sortedSet = [](std::vector<Corr> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  // Least-squares pose over all inliers, re-scored until the inlier set stops changing.
  for (int iter = 0; iter < 5 && s.inliers.size() >= 2; ++iter) {
    std::vector<Eigen::Vector3d> qs, ms;
    for (const auto& [i, j] : s.inliers) {
      qs.push_back(q[i].centroid);
      ms.push_back(m[j].centroid);
    }
    const ConstellationModel model =
        (c.model == ConstellationModel::Full3D && s.inliers.size() >= 3) ? ConstellationModel::Full3D
                                                                           : ConstellationModel::Planar;
    Scored next = score(fitTransform(qs, ms, model), corrs, q, m, c);
    if (next.inliers.size() < s.inliers.size()) break;
    const bool same = sortedSet(next.inliers) == sortedSet(s.inliers);
    s = std::move(next);
    if (same) break;
  }
  return s;
}

double triangleHeight(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double area2 = (b - a).cross(c - a).norm();
  const double longest = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()});
  return longest > 0 ? area2 / longest : 0.0;
}

}  // namespace

namespace {

// Minimal samples of correspondences: pairs (planar) or triples (3-D) whose landmarks are
// consistent (distances between landmarks are invariant to the unknown pose) and well spread;
// at most max_hypotheses, drawn at random from the first 8× as many.
std::vector<std::array<std::size_t, 3>> minimalSamples(const std::vector<Corr>& corrs,
                                                        const std::vector<PropertyLandmark>& q,
                                                        const std::vector<PropertyLandmark>& m,
                                                        const ConstellationConfig& c) {
  auto consistent = [&](const Corr& a, const Corr& b) {
    if (a.first == b.first || a.second == b.second) return false;
    const double dq = (q[a.first].centroid - q[b.first].centroid).norm();
    const double dm = (m[a.second].centroid - m[b.second].centroid).norm();
    return std::abs(dq - dm) <= kDistanceTolerance;
  };
  auto baselineOk = [&](const Corr& a, const Corr& b) {
    const Eigen::Vector3d d = q[a.first].centroid - q[b.first].centroid;
    const double len = c.model == ConstellationModel::Planar ? d.head<2>().norm() : d.norm();
    return len >= kConstellationMinPairDistance;
  };
  std::vector<std::array<std::size_t, 3>> samples;
  const std::size_t cap = kMaxHypotheses * 8;  // bound enumeration before sampling
  for (std::size_t a = 0; a < corrs.size() && samples.size() < cap; ++a)
    for (std::size_t b = a + 1; b < corrs.size() && samples.size() < cap; ++b) {
      if (!consistent(corrs[a], corrs[b]) || !baselineOk(corrs[a], corrs[b])) continue;
      if (c.model == ConstellationModel::Planar) {
        samples.push_back({a, b, b});
        continue;
      }
      for (std::size_t d = b + 1; d < corrs.size() && samples.size() < cap; ++d) {
        if (!consistent(corrs[a], corrs[d]) || !consistent(corrs[b], corrs[d])) continue;
        if (triangleHeight(q[corrs[a].first].centroid, q[corrs[b].first].centroid,
                           q[corrs[d].first].centroid) < kMinTriangleHeight)
          continue;
        samples.push_back({a, b, d});
      }
    }
  if (samples.size() > kMaxHypotheses) {
    std::mt19937_64 rng(c.seed);
    std::shuffle(samples.begin(), samples.end(), rng);
    samples.resize(kMaxHypotheses);
  }
  return samples;
}

// Ambiguity: another hypothesis explaining as many landmarks with a clearly different pose
// (e.g. a symmetric arrangement of same-class sources).
bool ambiguous(const std::vector<Scored>& hypotheses, const Scored& best, const std::vector<PropertyLandmark>& q,
               const ConstellationConfig& c) {
  Eigen::Vector3d q_mean = Eigen::Vector3d::Zero();
  for (const auto& lm : q) q_mean += lm.centroid;
  q_mean /= static_cast<double>(q.size());
  for (const auto& h : hypotheses) {
    if (h.inliers.size() < best.inliers.size() || h.value < best.value) continue;
    const double dt = (h.T * q_mean - best.T * q_mean).norm();
    const double dr = rotationAngle(h.T.inverse() * best.T);
    if (dt > 2.0 * c.inlier_distance || dr > 0.5) return true;
  }
  return false;
}

}  // namespace

// RANSAC over landmark correspondences: compatible pairs, minimal samples, a transform fitted
// and scored per sample, the best refined, then checked for overlap and ambiguity.
std::optional<ConstellationMatch> matchConstellations(const std::vector<PropertyLandmark>& q,
                                                      const std::vector<PropertyLandmark>& m,
                                                      const ConstellationConfig& c) {
  if (q.size() < c.min_inliers || m.size() < c.min_inliers) return std::nullopt;
  std::vector<Corr> corrs;
  for (std::size_t i = 0; i < q.size(); ++i)
    for (std::size_t j = 0; j < m.size(); ++j)
      if (compatible(q[i], m[j], c)) corrs.emplace_back(i, j);
  if (corrs.size() < c.min_inliers) return std::nullopt;

  const std::vector<std::array<std::size_t, 3>> samples = minimalSamples(corrs, q, m, c);
  if (samples.empty()) return std::nullopt;
  std::vector<Scored> hypotheses;
  hypotheses.reserve(samples.size());
  for (const auto& s : samples) {
    const std::size_t n = c.model == ConstellationModel::Planar ? 2 : 3;
    std::vector<Eigen::Vector3d> qs, ms;
    for (std::size_t k = 0; k < n; ++k) {
      qs.push_back(q[corrs[s[k]].first].centroid);
      ms.push_back(m[corrs[s[k]].second].centroid);
    }
    hypotheses.push_back(score(fitTransform(qs, ms, c.model), corrs, q, m, c));
  }
  std::size_t best = 0;
  for (std::size_t h = 1; h < hypotheses.size(); ++h)
    if (hypotheses[h].better(hypotheses[best])) best = h;
  Scored result = refine(hypotheses[best], corrs, q, m, c);
  if (result.inliers.size() < c.min_inliers) return std::nullopt;

  ConstellationMatch out;
  out.T_match_query = result.T;
  out.inliers = result.inliers;
  out.rmse = result.rmse;
  out.misses = result.misses;
  out.overlap = 2.0 * static_cast<double>(result.inliers.size()) /
                static_cast<double>(2 * result.inliers.size() + result.misses);
  if (out.overlap < kMinOverlap) return std::nullopt;
  out.ambiguous = ambiguous(hypotheses, result, q, c);
  return out;
}

std::vector<LoopCandidate> findConstellationCandidates(
    std::size_t query, const std::vector<std::vector<PropertyLandmark>>& lms,
    const CandidateSearchConfig& config) {
  validate(config);
  if (query >= lms.size()) fail("findConstellationCandidates", "query keyframe out of range");
  std::vector<LoopCandidate> out;
  if (query < config.min_index_gap) return out;
  for (std::size_t j = 0; j + config.min_index_gap <= query; ++j) {
    const auto match = matchConstellations(lms[query], lms[j], config.constellation);
    if (!match || match->ambiguous) continue;
    LoopCandidate cand;
    cand.query = query;
    cand.match = j;
    cand.initial_guess = match->T_match_query;
    cand.source = CandidateSource::Constellation;
    cand.inliers = match->inliers.size();
    cand.rmse = match->rmse;
    cand.score = static_cast<double>(cand.inliers) -
                 kMissPenalty * static_cast<double>(match->misses) -
                 match->rmse / config.constellation.inlier_distance;
    out.push_back(cand);
  }
  // LoopCandidate holds an Isometry3d: std::stable_sort's scratch buffer would misalign it under AVX.
  stableSortAligned(out, [](const LoopCandidate& a, const LoopCandidate& b) { return a.score > b.score; });
  if (out.size() > config.max_candidates) out.resize(config.max_candidates);
  return out;
}

std::vector<LoopCandidate> findDistanceCandidates(std::size_t query, const PoseList& poses,
                                                  const CandidateSearchConfig& config) {
  validate(config);
  if (query >= poses.size()) fail("findDistanceCandidates", "query keyframe out of range");
  std::vector<LoopCandidate> out;
  if (query < config.min_index_gap) return out;
  const Eigen::Isometry3d& Tq = poses[query];
  for (std::size_t j = 0; j + config.min_index_gap <= query; ++j) {
    const double d = (poses[j].translation() - Tq.translation()).norm();
    if (!(d <= config.search_radius)) continue;
    LoopCandidate cand;
    cand.query = query;
    cand.match = j;
    cand.initial_guess = poses[j].inverse() * Tq;
    cand.source = CandidateSource::Distance;
    cand.score = -d;
    cand.rmse = d;
    out.push_back(cand);
  }
  // LoopCandidate holds an Isometry3d: std::stable_sort's scratch buffer would misalign it under AVX.
  stableSortAligned(out, [](const LoopCandidate& a, const LoopCandidate& b) { return a.score > b.score; });
  if (out.size() > config.max_candidates) out.resize(config.max_candidates);
  return out;
}

}  // namespace hazmap
