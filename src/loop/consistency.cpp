#include "hazmap/loop/consistency.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

// Floors of the drift model (issue 37: constants, not keys): a loop between keyframes a few metres
// apart is still allowed the scan-matching error of a sparse VLP-16 keyframe, about 0.1 m / 0.6°.
constexpr double kTranslationSigmaFloor = 0.1;  // m
constexpr double kRotationSigmaFloor = 0.01;    // rad

double pathLength(const PoseList& poses, std::size_t a, std::size_t b) {
  if (a > b) std::swap(a, b);
  if (b >= poses.size()) fail("pathLength", "keyframe index out of range");
  double len = 0.0;
  for (std::size_t i = a; i < b; ++i)
    len += (poses[i + 1].translation() - poses[i].translation()).norm();
  return len;
}

Matrix6d driftCovariance(double L, const ConsistencyConfig& c) {
  const double st = kTranslationSigmaFloor + c.translation_drift_per_metre * L;
  const double sr = kRotationSigmaFloor + c.rotation_drift_per_metre * L;
  Vector6d d;
  d << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr;
  return d.asDiagonal();
}

double chiSquareQuantile(int dof, double p) {
  if (!(p > 0.0 && p < 1.0)) fail("chiSquareQuantile", "probability must be in (0, 1)");
  if (dof != 3 && dof != 6) fail("chiSquareQuantile", "degrees of freedom must be 3 or 6");
  // Closed-form CDFs: 3 dof P(3/2, x/2) = erf(√(x/2)) − √(2x/π) e^(−x/2); 6 dof 1 − e^(−x/2) (1 + x/2 + x²/8).
  const auto cdf = [dof](double x) {
    return dof == 3 ? std::erf(std::sqrt(0.5 * x)) - std::sqrt(2.0 * x / M_PI) * std::exp(-0.5 * x)
                    : 1.0 - std::exp(-x / 2) * (1 + x / 2 + x * x / 8);
  };
  double lo = 0.0, hi = 1.0;
  while (cdf(hi) < p && hi < 1e6) hi *= 2;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

namespace {

double mahalanobis2(const Vector6d& e, const Matrix6d& cov) {
  const Matrix6d s = 0.5 * (cov + cov.transpose());
  return e.dot(s.ldlt().solve(e));
}

}  // namespace

namespace {

// Gate 1's d² with the path length between the loop's keyframes given.
double driftGateDistance2(const LoopClosure& loop, const PoseList& poses, double path_length,
                          const ConsistencyConfig& c) {
  const Eigen::Isometry3d predicted = poses[loop.from].inverse() * poses[loop.to];
  // Left-perturbation error in the `from` frame, the convention of the loop covariance.
  const Vector6d e = se3Log(loop.T_from_to * predicted.inverse());
  return mahalanobis2(e, loop.covariance + driftCovariance(path_length, c));
}

// The cycle of two loops with the length of its two estimate paths given.
double pairwiseDistance2Along(const LoopClosure& a, const LoopClosure& b, const PoseList& poses, double path_length,
                              const ConsistencyConfig& c) {
  const Eigen::Isometry3d T_ik = poses[a.from].inverse() * poses[b.from];
  const Eigen::Isometry3d T_lj = poses[b.to].inverse() * poses[a.to];
  // Both routes from i to j: the loop a directly, or estimate i→k, loop b, estimate l→j.
  const Eigen::Isometry3d via_b = T_ik * b.T_from_to * T_lj;
  const Vector6d e = se3Log(a.T_from_to * via_b.inverse());
  // First-order: the covariances of both loops and the drift of the two short estimate paths.
  return mahalanobis2(e, a.covariance + b.covariance + driftCovariance(path_length, c));
}

// Path length along `poses` from the first pose to each: a path between two keyframes is a
// difference, O(1) instead of a sum along it (the consistency check asks for every pair of loops:
// on a long mission with hundreds of loops the sums were most of the back end's time).
class CumulativePath {
 public:
  explicit CumulativePath(const PoseList& poses) : from_start_(poses.size(), 0.0) {
    for (std::size_t i = 1; i < poses.size(); ++i)
      from_start_[i] = from_start_[i - 1] + (poses[i].translation() - poses[i - 1].translation()).norm();
  }
  double between(std::size_t a, std::size_t b) const { return std::abs(from_start_[b] - from_start_[a]); }

 private:
  std::vector<double> from_start_;
};

// Which pairs of loops are consistent, one bit per pair: row i bit j. Words of 64 loops, so the
// exact search reads a row as a vertex set and the greedy one tests a loop against all kept at once.
class BitRows {
 public:
  std::size_t size() const { return rows_.size(); }
  const std::vector<std::uint64_t>& row(std::size_t i) const { return rows_[i]; }
  /// A new loop, consistent with the earlier loops where `with[j]`.
  void append(const std::vector<char>& with) {
    const std::size_t n = rows_.size(), words = n / 64 + 1;
    for (auto& r : rows_) r.resize(words, 0);
    std::vector<std::uint64_t> mine(words, 0);
    for (std::size_t j = 0; j < n; ++j)
      if (with[j]) {
        mine[j / 64] |= std::uint64_t{1} << (j % 64);
        rows_[j][n / 64] |= std::uint64_t{1} << (n % 64);
      }
    rows_.push_back(std::move(mine));
  }
  /// Loop k forgotten: the later loops move down one place.
  void erase(std::size_t k) {
    rows_.erase(rows_.begin() + static_cast<std::ptrdiff_t>(k));
    const std::size_t n = rows_.size(), words = std::max<std::size_t>(1, (n + 63) / 64);
    for (auto& r : rows_) {
      std::vector<std::uint64_t> out(words, 0);
      for (std::size_t j = 0, o = 0; j <= n; ++j) {  // the old indices
        if (j == k) continue;
        if ((r[j / 64] >> (j % 64)) & 1u) out[o / 64] |= std::uint64_t{1} << (o % 64);
        ++o;
      }
      r = std::move(out);
    }
  }
  std::size_t degree(std::size_t i) const {
    std::size_t d = 0;
    for (std::uint64_t w : rows_[i]) d += static_cast<std::size_t>(std::popcount(w));
    return d;
  }

 private:
  std::vector<std::vector<std::uint64_t>> rows_;
};

// Each loop's drift-gate distance and which pairs of loops are consistent, for the estimate given.
struct ConsistencyGraph {
  std::vector<double> cost;
  BitRows adj;
};

void checkInRange(const std::vector<LoopClosure>& loops, const PoseList& poses) {
  for (const LoopClosure& l : loops)
    if (std::max(l.from, l.to) >= poses.size()) fail("consistentSubset", "loop keyframe index out of range of the pose estimate");
}

std::vector<double> driftGateCosts(const std::vector<LoopClosure>& loops, const PoseList& poses, const CumulativePath& path,
                                   const ConsistencyConfig& c) {
  std::vector<double> cost(loops.size());
  for (std::size_t i = 0; i < loops.size(); ++i)
    cost[i] = driftGateDistance2(loops[i], poses, path.between(loops[i].from, loops[i].to), c);
  return cost;
}

// Loop `k` against each of loops[0, k): consistent where the cycle's d² is within `threshold`.
std::vector<char> consistentWithEarlier(const std::vector<LoopClosure>& loops, std::size_t k, const PoseList& poses,
                                        const CumulativePath& path, double threshold, const ConsistencyConfig& c) {
  std::vector<char> with(k, 0);
  const LoopClosure& b = loops[k];
  for (std::size_t i = 0; i < k; ++i) {
    const LoopClosure& a = loops[i];
    const double L = path.between(a.from, b.from) + path.between(b.to, a.to);
    with[i] = pairwiseDistance2Along(a, b, poses, L, c) <= threshold;
  }
  return with;
}

ConsistencyGraph consistencyGraph(const std::vector<LoopClosure>& loops, const PoseList& poses,
                                  const ConsistencyConfig& c) {
  checkInRange(loops, poses);
  const CumulativePath path(poses);
  const double threshold = chiSquareQuantile(6, c.gate_probability);
  ConsistencyGraph g{driftGateCosts(loops, poses, path, c), {}};
  for (std::size_t k = 0; k < loops.size(); ++k) g.adj.append(consistentWithEarlier(loops, k, poses, path, threshold, c));
  return g;
}

// Bron–Kerbosch with pivoting on 64-bit vertex sets: the exact maximum clique (n ≤ 64); ties
// prefer the smaller summed cost.
std::vector<std::size_t> maximumClique(const std::vector<double>& cost, const BitRows& adj) {
  const std::size_t n = adj.size();
  std::vector<std::uint64_t> nbr(n, 0);
  for (std::size_t i = 0; i < n; ++i) nbr[i] = adj.row(i)[0];
  std::vector<std::size_t> best, current;
  double best_cost = 0.0;
  std::function<void(std::uint64_t, std::uint64_t)> expand = [&](std::uint64_t P, std::uint64_t X) {
    if (P == 0) {
      if (X != 0) return;
      double s = 0.0;
      for (std::size_t v : current) s += cost[v];
      if (current.size() > best.size() || (current.size() == best.size() && s < best_cost)) {
        best = current;
        best_cost = s;
      }
      return;
    }
    if (current.size() + static_cast<std::size_t>(std::popcount(P)) < best.size()) return;
    const int pivot = std::countr_zero(P | X);
    std::uint64_t candidates = P & ~nbr[pivot];
    while (candidates) {
      const int v = std::countr_zero(candidates);
      candidates &= candidates - 1;
      current.push_back(static_cast<std::size_t>(v));
      expand(P & nbr[v], X & nbr[v]);
      current.pop_back();
      P &= ~(std::uint64_t{1} << v);
      X |= std::uint64_t{1} << v;
    }
  };
  expand(n == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << n) - 1, 0);
  return best;
}

// Greedy (n > 64): most-connected loops first, each kept if consistent with all kept so far.
std::vector<std::size_t> greedyClique(const std::vector<double>& cost, const BitRows& adj) {
  const std::size_t n = adj.size();
  std::vector<std::size_t> order(n), degree(n);
  for (std::size_t i = 0; i < n; ++i) {
    order[i] = i;
    degree[i] = adj.degree(i);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return degree[a] != degree[b] ? degree[a] > degree[b] : cost[a] < cost[b];
  });
  std::vector<std::size_t> kept;
  std::vector<std::uint64_t> kept_set((n + 63) / 64, 0);
  for (std::size_t v : order) {
    const auto& row = adj.row(v);
    bool ok = true;
    for (std::size_t w = 0; w < kept_set.size() && ok; ++w) ok = (kept_set[w] & ~row[w]) == 0;
    if (!ok) continue;
    kept.push_back(v);
    kept_set[v / 64] |= std::uint64_t{1} << (v % 64);
  }
  return kept;
}

std::vector<std::size_t> largestConsistentSet(const std::vector<double>& cost, const BitRows& adj) {
  const std::size_t n = adj.size();
  if (n <= 1) {
    std::vector<std::size_t> all(n);
    for (std::size_t i = 0; i < n; ++i) all[i] = i;
    return all;
  }
  std::vector<std::size_t> best = n <= 64 ? maximumClique(cost, adj) : greedyClique(cost, adj);
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace

GateResult driftGate(const LoopClosure& loop, const PoseList& poses, const ConsistencyConfig& c) {
  validate(c);
  if (loop.from >= poses.size() || loop.to >= poses.size())
    fail("driftGate", "loop keyframe index out of range of the pose estimate");
  GateResult g;
  g.path_length = pathLength(poses, loop.from, loop.to);
  g.threshold = chiSquareQuantile(6, c.gate_probability);
  g.mahalanobis2 = driftGateDistance2(loop, poses, g.path_length, c);
  g.accepted = g.mahalanobis2 <= g.threshold;
  return g;
}

GateResult innovationGate(const LoopClosure& loop, const PoseList& poses, const Matrix6d& relative_covariance,
                          double probability) {
  if (loop.from >= poses.size() || loop.to >= poses.size())
    fail("innovationGate", "loop keyframe index out of range of the pose estimate");
  if (!relative_covariance.allFinite()) fail("innovationGate", "non-finite relative covariance");
  GateResult g;
  g.path_length = pathLength(poses, loop.from, loop.to);
  g.threshold = chiSquareQuantile(6, probability);
  const Eigen::Isometry3d predicted = poses[loop.from].inverse() * poses[loop.to];
  const Vector6d e = se3Log(loop.T_from_to * predicted.inverse());
  g.mahalanobis2 = mahalanobis2(e, loop.covariance + relative_covariance);
  g.accepted = g.mahalanobis2 <= g.threshold;
  return g;
}

double pairwiseDistance2(const LoopClosure& a, const LoopClosure& b, const PoseList& poses,
                         const ConsistencyConfig& c) {
  const std::size_t i = a.from, j = a.to, k = b.from, l = b.to;
  if (std::max({i, j, k, l}) >= poses.size())
    fail("pairwiseDistance2", "loop keyframe index out of range of the pose estimate");
  return pairwiseDistance2Along(a, b, poses, pathLength(poses, i, k) + pathLength(poses, l, j), c);
}

std::vector<std::size_t> consistentSubset(const std::vector<LoopClosure>& loops, const PoseList& poses,
                                          const ConsistencyConfig& c) {
  validate(c);
  const ConsistencyGraph g = consistencyGraph(loops, poses, c);
  return largestConsistentSet(g.cost, g.adj);
}

// The loops whose pairs are remembered, in order, and the pairs' verdicts.
struct IncrementalConsistency::Remembered {
  std::vector<LoopClosure> loops;
  BitRows adj;

  static bool same(const LoopClosure& a, const LoopClosure& b) {
    return a.from == b.from && a.to == b.to && a.T_from_to.matrix() == b.T_from_to.matrix();
  }
  // Forgets what `now` no longer holds (loops keep their order) and tests the new loops against
  // all; returns the number of pair tests.
  std::size_t catchUp(const std::vector<LoopClosure>& now, const PoseList& poses, const CumulativePath& path,
                      const ConsistencyConfig& c) {
    std::size_t i = 0;
    for (std::size_t k = 0; k < loops.size();) {
      if (i < now.size() && same(loops[k], now[i])) {
        ++k;
        ++i;
        continue;
      }
      adj.erase(k);
      loops.erase(loops.begin() + static_cast<std::ptrdiff_t>(k));
    }
    const double threshold = chiSquareQuantile(6, c.gate_probability);
    std::size_t tests = 0;
    for (; i < now.size(); ++i) {
      loops.push_back(now[i]);
      adj.append(consistentWithEarlier(loops, i, poses, path, threshold, c));
      tests += i;
    }
    return tests;
  }
};

IncrementalConsistency::IncrementalConsistency(ConsistencyConfig config) : config_(config) {}
IncrementalConsistency::~IncrementalConsistency() = default;
IncrementalConsistency::IncrementalConsistency(IncrementalConsistency&&) noexcept = default;
IncrementalConsistency& IncrementalConsistency::operator=(IncrementalConsistency&&) noexcept = default;

std::size_t IncrementalConsistency::pairTests() const { return pair_tests_; }

std::vector<std::size_t> IncrementalConsistency::subset(const std::vector<LoopClosure>& loops, const PoseList& poses) {
  const std::size_t n = loops.size();
  if (n <= 64) {
    remembered_.reset();
    pair_tests_ += n < 2 ? 0 : n * (n - 1) / 2;
    return consistentSubset(loops, poses, config_);
  }
  validate(config_);
  checkInRange(loops, poses);
  if (!remembered_) remembered_ = std::make_unique<Remembered>();
  const CumulativePath path(poses);
  pair_tests_ += remembered_->catchUp(loops, poses, path, config_);
  return largestConsistentSet(driftGateCosts(loops, poses, path, config_), remembered_->adj);
}

}  // namespace hazmap
