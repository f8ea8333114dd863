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

// Gate 1 with the path length between the loop's keyframes given.
GateResult driftGateAlong(const LoopClosure& loop, const PoseList& poses, double path_length,
                          const ConsistencyConfig& c) {
  GateResult g;
  g.path_length = path_length;
  g.threshold = chiSquareQuantile(6, c.gate_probability);
  const Eigen::Isometry3d predicted = poses[loop.from].inverse() * poses[loop.to];
  // Left-perturbation error in the `from` frame, the convention of the loop covariance.
  const Vector6d e = se3Log(loop.T_from_to * predicted.inverse());
  g.mahalanobis2 = mahalanobis2(e, loop.covariance + driftCovariance(g.path_length, c));
  g.accepted = g.mahalanobis2 <= g.threshold;
  return g;
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

// Each loop's drift-gate distance, and which pairs of loops are consistent.
struct ConsistencyGraph {
  std::vector<double> cost;
  std::vector<std::vector<char>> adj;
};
ConsistencyGraph consistencyGraph(const std::vector<LoopClosure>& loops, const PoseList& poses,
                                  const ConsistencyConfig& c) {
  for (const LoopClosure& l : loops)
    if (std::max(l.from, l.to) >= poses.size()) fail("consistentSubset", "loop keyframe index out of range of the pose estimate");
  const std::size_t n = loops.size();
  const double threshold = chiSquareQuantile(6, c.gate_probability);
  const CumulativePath path(poses);
  ConsistencyGraph g{std::vector<double>(n), std::vector<std::vector<char>>(n, std::vector<char>(n, 0))};
  for (std::size_t i = 0; i < n; ++i)
    g.cost[i] = driftGateAlong(loops[i], poses, path.between(loops[i].from, loops[i].to), c).mahalanobis2;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const LoopClosure &a = loops[i], &b = loops[j];
      const double L = path.between(a.from, b.from) + path.between(b.to, a.to);
      g.adj[i][j] = g.adj[j][i] = pairwiseDistance2Along(a, b, poses, L, c) <= threshold;
    }
  return g;
}

}  // namespace

GateResult driftGate(const LoopClosure& loop, const PoseList& poses, const ConsistencyConfig& c) {
  validate(c);
  if (loop.from >= poses.size() || loop.to >= poses.size())
    fail("driftGate", "loop keyframe index out of range of the pose estimate");
  return driftGateAlong(loop, poses, pathLength(poses, loop.from, loop.to), c);
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
  const std::size_t n = loops.size();
  if (n <= 1) {
    std::vector<std::size_t> all(n);
    for (std::size_t i = 0; i < n; ++i) all[i] = i;
    return all;
  }
  const auto [cost, adj] = consistencyGraph(loops, poses, c);
  std::vector<std::size_t> best;
  double best_cost = 0.0;
  auto consider = [&](const std::vector<std::size_t>& clique) {
    double s = 0.0;
    for (std::size_t v : clique) s += cost[v];
    if (clique.size() > best.size() || (clique.size() == best.size() && s < best_cost)) {
      best = clique;
      best_cost = s;
    }
  };

  if (n <= 64) {
    // Bron–Kerbosch with pivoting on 64-bit vertex sets: exact maximum clique.
    std::vector<std::uint64_t> nbr(n, 0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j)
        if (adj[i][j]) nbr[i] |= std::uint64_t{1} << j;
    std::vector<std::size_t> current;
    std::function<void(std::uint64_t, std::uint64_t)> expand = [&](std::uint64_t P, std::uint64_t X) {
      if (P == 0) {
        if (X == 0) consider(current);
        return;
      }
      if (current.size() + static_cast<std::size_t>(std::popcount(P)) < best.size()) return;
      const std::uint64_t PX = P | X;
      const int pivot = std::countr_zero(PX);
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
    const std::uint64_t all = n == 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << n) - 1;
    expand(all, 0);
  } else {
    // Greedy: most-connected loops first, each kept if consistent with all kept so far.
    std::vector<std::size_t> order(n);
    for (std::size_t i = 0; i < n; ++i) order[i] = i;
    std::vector<int> degree(n, 0);
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j) degree[i] += adj[i][j];
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
      return degree[a] != degree[b] ? degree[a] > degree[b] : cost[a] < cost[b];
    });
    std::vector<std::size_t> kept;
    for (std::size_t v : order) {
      bool ok = true;
      for (std::size_t u : kept) ok = ok && adj[u][v];
      if (ok) kept.push_back(v);
    }
    consider(kept);
  }
  std::sort(best.begin(), best.end());
  return best;
}

}  // namespace hazmap
