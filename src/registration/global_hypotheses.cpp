// Hypothesis generation for global registration: RANSAC over descriptor matches with the
// edge-length pre-check (a rigid motion keeps distances, so a triple whose source and target
// edges disagree cannot be all inliers and costs no model fit), and the property-landmark
// constellations (triples of same-class clusters whose pairwise distances agree).
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <random>
#include <span>

#include "global_internal.hpp"
#include "hazmap/core/stable_sort.hpp"

namespace hazmap::global {
namespace {

// Internal thresholds of global registration (issue 37: named constants, not keys; their old
// keys name this file). docs/registration.md, "Global registration".
/// Pre-check: every edge-length ratio of a RANSAC triple >= this (a rigid motion keeps lengths; 10 % allows voxel noise).
constexpr double kEdgeLengthSimilarity = 0.9;
/// m; hypotheses farther apart are distinct (about two voxels of the downsampled clouds)…
constexpr double kDistinctTranslation = 1.0;
/// …or rotated more than this (degrees).
constexpr double kDistinctRotationDeg = 10.0;


// The rigid motion that maps triangle a onto triangle b, from the orthonormal frames the two
// triangles span (first edge, normal, their cross product) — exact for a consistent pair, an
// order of magnitude cheaper than an SVD; each hypothesis is re-fitted on its inliers later.
Eigen::Isometry3d fitTriad(const std::vector<Eigen::Vector3f>& a, const std::vector<Eigen::Vector3f>& b) {
  auto frame = [](const std::vector<Eigen::Vector3f>& p) {
    Eigen::Matrix3d F;
    const Eigen::Vector3d x = (p[1] - p[0]).cast<double>().normalized();
    const Eigen::Vector3d z = x.cross((p[2] - p[0]).cast<double>()).normalized();
    F << x, z.cross(x), z;
    return F;
  };
  const Eigen::Matrix3d R = frame(b) * frame(a).transpose();
  const Eigen::Vector3d ca = ((a[0] + a[1] + a[2]) / 3.0f).cast<double>();
  const Eigen::Vector3d cb = ((b[0] + b[1] + b[2]) / 3.0f).cast<double>();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = cb - R * ca;
  return T;
}

bool edgesAgree(float a, float b, float similarity) {
  return std::min(a, b) >= similarity * std::max(a, b);
}

constexpr std::size_t kPretest = 64;

std::size_t countAgreeing(const Eigen::Isometry3d& T, const std::vector<Eigen::Vector3f>& src,
                          const std::vector<Eigen::Vector3f>& dst, std::span<const Match> m, float d2,
                          std::vector<std::size_t>* which = nullptr) {
  const Eigen::Matrix3f R = T.linear().cast<float>();
  const Eigen::Vector3f t = T.translation().cast<float>();
  std::size_t n = 0;
  for (std::size_t k = 0; k < m.size(); ++k) {
    if ((R * src[m[k].source] + t - dst[m[k].target]).squaredNorm() < d2) {
      ++n;
      if (which) which->push_back(k);
    }
  }
  return n;
}

// Sorted by votes (descending; ties by insertion order) and thinned to pairwise distinct poses.
std::vector<Hypothesis> bestDistinct(std::vector<Hypothesis> all, std::size_t keep) {
  // Hypothesis holds an Isometry3d: std::stable_sort's scratch buffer would misalign it under AVX.
  stableSortAligned(all, [](const Hypothesis& a, const Hypothesis& b) { return a.votes > b.votes; });
  std::vector<Hypothesis> out;
  for (const auto& h : all) {
    if (out.size() >= keep) break;
    bool fresh = true;
    for (const auto& o : out) fresh = fresh && distinct(h.transform, o.transform);
    if (fresh) out.push_back(h);
  }
  return out;
}

// Pairwise consistency of matches: a rigid motion keeps distances, so two inlier matches span
// source and target edges of about the same length (and long enough to fix a rotation). Drawing
// the second and third match of a triple among those consistent with the first (and each other)
// makes an all-inlier triple far likelier than uniform draws when few matches are right (as in
// SC²-PCR / TEASER's consistency graph; here only to guide the sampling).
struct Compatibility {
  std::vector<std::vector<std::uint32_t>> partners;  ///< per match, the consistent ones
  std::vector<std::uint64_t> bits;                   ///< row-major bit matrix of the same
  std::size_t words = 0;
  bool test(std::size_t i, std::size_t j) const { return (bits[i * words + j / 64] >> (j % 64)) & 1u; }
};

Compatibility compatibility(const std::vector<Eigen::Vector3f>& src, const std::vector<Eigen::Vector3f>& dst,
                            const std::vector<Match>& m, const GlobalRegistrationConfig& config) {
  Compatibility c;
  const std::size_t n = m.size();
  c.words = (n + 63) / 64;
  c.bits.assign(n * c.words, 0);
  c.partners.resize(n);
  const float sim = static_cast<float>(kEdgeLengthSimilarity);
  const float min_edge = static_cast<float>(config.inlier_distance);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    for (std::size_t j = 0; j < n; ++j) {
      if (j == i) continue;
      const float ls = (src[m[i].source] - src[m[j].source]).norm();
      const float lt = (dst[m[i].target] - dst[m[j].target]).norm();
      if (ls < min_edge || !edgesAgree(ls, lt, sim)) continue;
      c.partners[i].push_back(static_cast<std::uint32_t>(j));
      c.bits[i * c.words + j / 64] |= std::uint64_t{1} << (j % 64);
    }
  });
  return c;
}

// One block of RANSAC draws with its own generator: the result is the same for any number of
// threads. Keeps the block's best few hypotheses.
std::vector<Hypothesis> ransacBlock(std::uint64_t seed, int draws, const std::vector<Eigen::Vector3f>& src,
                                    const std::vector<Eigen::Vector3f>& dst, const std::vector<Match>& m,
                                    const Compatibility& compat, const GlobalRegistrationConfig& config,
                                    std::size_t keep) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<std::size_t> pick(0, m.size() - 1);
  const float d2 = static_cast<float>(config.inlier_distance * config.inlier_distance);
  const float min_edge = static_cast<float>(config.inlier_distance);
  // Many more than `keep`: near-duplicates of the best crowd the top, and thinning keeps one each.
  const std::size_t kPool = 16 * keep;
  auto fewerVotes = [](const Hypothesis& x, const Hypothesis& y) { return x.votes > y.votes; };
  std::vector<Hypothesis> best;
  double best_votes = 0.0;
  std::vector<Eigen::Vector3f> a(3), b(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto among = [&](const std::vector<std::uint32_t>& v) { return v[static_cast<std::size_t>(unit(rng) * v.size()) % v.size()]; };
  for (int it = 0; it < draws; ++it) {
    const std::size_t i = pick(rng);
    const auto& ci = compat.partners[i];
    if (ci.size() < 2) continue;
    const std::size_t j = among(ci);
    std::size_t k = i;
    for (int attempt = 0; attempt < 8 && k == i; ++attempt) {
      const std::size_t cand = among(ci);
      if (cand != j && compat.test(j, cand)) k = cand;
    }
    if (k == i) continue;
    const std::size_t idx[3] = {i, j, k};
    for (int e = 0; e < 3; ++e) {
      a[e] = src[m[idx[e]].source];
      b[e] = dst[m[idx[e]].target];
    }
    // A near-collinear triple leaves the rotation about its line undetermined.
    if ((a[1] - a[0]).cross(a[2] - a[0]).norm() < 0.5f * min_edge * min_edge) continue;
    Hypothesis h;
    h.transform = fitTriad(a, b);
    // The triple itself must fit (Open3D's distance checker): cheaper than counting.
    bool fits = true;
    for (int e = 0; e < 3 && fits; ++e) fits = (h.transform.cast<float>() * a[e] - b[e]).squaredNorm() < d2;
    if (!fits) continue;
    // Pre-test on the first matches (shuffled, so a random sample): a hypothesis far below the
    // best so far is not counted in full.
    const std::size_t pre = std::min<std::size_t>(m.size(), kPretest);
    const std::size_t pre_votes = countAgreeing(h.transform, src, dst, std::span(m).first(pre), d2);
    if (static_cast<double>(pre_votes) * static_cast<double>(m.size()) / static_cast<double>(pre) < 0.5 * best_votes)
      continue;
    h.votes = static_cast<double>(countAgreeing(h.transform, src, dst, m, d2));
    if (h.votes <= 3) continue;  // the triple alone: no support
    best_votes = std::max(best_votes, h.votes);
    // A bounded min-heap of the block's best by votes; distinctness is sorted out at the end.
    if (best.size() < kPool) {
      best.push_back(h);
      std::push_heap(best.begin(), best.end(), fewerVotes);
    } else if (h.votes > best.front().votes) {
      std::pop_heap(best.begin(), best.end(), fewerVotes);
      best.back() = h;
      std::push_heap(best.begin(), best.end(), fewerVotes);
    }
  }
  return bestDistinct(std::move(best), keep);
}

}  // namespace

Eigen::Isometry3d fitRigid(const std::vector<Eigen::Vector3f>& src, const std::vector<Eigen::Vector3f>& dst) {
  Eigen::Vector3d cs = Eigen::Vector3d::Zero(), cd = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i) {
    cs += src[i].cast<double>();
    cd += dst[i].cast<double>();
  }
  cs /= static_cast<double>(src.size());
  cd /= static_cast<double>(src.size());
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < src.size(); ++i)
    H += (src[i].cast<double>() - cs) * (dst[i].cast<double>() - cd).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0) D(2, 2) = -1.0;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = svd.matrixV() * D * svd.matrixU().transpose();
  T.translation() = cd - T.linear() * cs;
  return T;
}

bool distinct(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  const double angle = Eigen::AngleAxisd(d.linear()).angle() * 180.0 / std::numbers::pi;
  return d.translation().norm() > kDistinctTranslation || angle > kDistinctRotationDeg;
}

std::vector<Hypothesis> ransacHypotheses(const std::vector<Eigen::Vector3f>& src,
                                         const std::vector<Eigen::Vector3f>& dst, const std::vector<Match>& matches,
                                         const GlobalRegistrationConfig& config, std::size_t keep) {
  if (matches.size() < 3) return {};
  // Shuffled once (deterministically), so any prefix is a random sample for the pre-test.
  std::vector<Match> m = matches;
  std::shuffle(m.begin(), m.end(), std::mt19937_64(config.seed));
  const Compatibility compat = compatibility(src, dst, m, config);
  constexpr int kBlock = 1000;
  const int blocks = (config.ransac_iterations + kBlock - 1) / kBlock;
  std::vector<std::vector<Hypothesis>> per_block(blocks);
  tbb::parallel_for(0, blocks, [&](int b) {
    const int draws = std::min(kBlock, config.ransac_iterations - b * kBlock);
    per_block[b] = ransacBlock(config.seed * 0x9E3779B97F4A7C15ULL + static_cast<std::uint64_t>(b), draws, src,
                               dst, m, compat, config, keep);
  });
  std::vector<Hypothesis> all;
  for (auto& v : per_block) all.insert(all.end(), v.begin(), v.end());
  all = bestDistinct(std::move(all), keep);
  // Re-fit each on the matches that agree with it (the triple alone is noisy).
  const float d2 = static_cast<float>(config.inlier_distance * config.inlier_distance);
  for (auto& h : all) {
    std::vector<std::size_t> agree;
    countAgreeing(h.transform, src, dst, m, d2, &agree);
    if (agree.size() < 3) continue;
    std::vector<Eigen::Vector3f> a, b;
    for (std::size_t k : agree) {
      a.push_back(src[m[k].source]);
      b.push_back(dst[m[k].target]);
    }
    const Eigen::Isometry3d refit = fitRigid(a, b);
    const double votes = static_cast<double>(countAgreeing(refit, src, dst, m, d2));
    if (votes >= h.votes) h = {refit, votes, false};
  }
  return bestDistinct(std::move(all), keep);
}

// ---------------------------------------------------------------------------------------------
std::vector<Hypothesis> constellationHypotheses(const std::vector<Landmark>& s, const std::vector<Landmark>& t,
                                                const GlobalRegistrationConfig& config, std::size_t keep) {
  // Landmark pairs that may correspond: same class.
  std::vector<Match> pairs;
  for (std::uint32_t i = 0; i < s.size(); ++i)
    for (std::uint32_t j = 0; j < t.size(); ++j)
      if (s[i].cls == t[j].cls) pairs.push_back({i, j});
  constexpr std::size_t kMaxPairs = 400;  // 400³/6 ≈ 10⁷ triples at most, most cut by the first edge
  if (pairs.size() < 3 || pairs.size() > kMaxPairs) return {};
  // A centroid moves with the view (which part of a source the scan saw): a looser tolerance.
  const float tol = static_cast<float>(2.0 * config.inlier_distance);
  auto agree = [&](const Match& p, const Match& q) {
    if (p.source == q.source || p.target == q.target) return false;
    const float ls = (s[p.source].centroid - s[q.source].centroid).norm();
    const float lt = (t[p.target].centroid - t[q.target].centroid).norm();
    return ls >= tol && std::abs(ls - lt) <= tol;
  };
  std::vector<Hypothesis> all;
  std::vector<Eigen::Vector3f> src_c, dst_c;
  for (const auto& l : s) src_c.push_back(l.centroid);
  for (const auto& l : t) dst_c.push_back(l.centroid);
  const float d2 = tol * tol;
  constexpr std::size_t kMaxHypotheses = 20000;
  for (std::size_t a = 0; a < pairs.size() && all.size() < kMaxHypotheses; ++a)
    for (std::size_t b = a + 1; b < pairs.size(); ++b) {
      if (!agree(pairs[a], pairs[b])) continue;
      for (std::size_t c = b + 1; c < pairs.size(); ++c) {
        if (!agree(pairs[a], pairs[c]) || !agree(pairs[b], pairs[c])) continue;
        Hypothesis h;
        h.transform = fitRigid({src_c[pairs[a].source], src_c[pairs[b].source], src_c[pairs[c].source]},
                               {dst_c[pairs[a].target], dst_c[pairs[b].target], dst_c[pairs[c].target]});
        h.votes = static_cast<double>(countAgreeing(h.transform, src_c, dst_c, pairs, d2));
        h.constellation = true;
        all.push_back(h);
      }
    }
  return bestDistinct(std::move(all), keep);
}

}  // namespace hazmap::global
