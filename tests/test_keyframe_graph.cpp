// The keyframes' pose graph (graph/keyframe_graph.hpp): a long mission's online solves fold the
// odometry chains between keyframes; the keyframes land where the whole graph's solve puts them.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/graph/keyframe_graph.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

Matrix6d diagonalInformation(double sigma_t, double sigma_r) {
  Matrix6d info = Matrix6d::Zero();
  info.diagonal() << Eigen::Vector3d::Constant(1 / (sigma_t * sigma_t)), Eigen::Vector3d::Constant(1 / (sigma_r * sigma_r));
  return info;
}

struct Mission {
  PoseGraph graph;
  std::vector<Eigen::Isometry3d> truth;
  std::vector<int> keyframes;  // every 4th frame, and frame 0
};

/// Three laps of a 20 m × 10 m rectangle in 0.25 m steps, slowly climbing; noisy odometry with
/// correlated (random) informations, a keyframe every 4th frame, loops from the later laps'
/// keyframes to the first lap's, an anchor-like edge between neighbouring keyframes, and gravity
/// priors on the keyframes.
Mission makeMission(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Mission m;
  const int lap = 240;
  m.truth = test::rectangleLaps(3, 0.25, 0.005);
  PoseGraph& g = m.graph;
  for (std::size_t i = 0; i < m.truth.size(); ++i) g.addNode(Eigen::Isometry3d::Identity());
  const auto noisy = [&](const Eigen::Isometry3d& T, double st, double sr) {
    Vector6d xi;
    for (int k = 0; k < 3; ++k) xi(k) = st * n(rng);
    for (int k = 3; k < 6; ++k) xi(k) = sr * n(rng);
    return se3Exp(xi) * T;
  };
  for (int i = 0; i + 1 < g.numNodes(); ++i) {
    Matrix6d A;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) A(r, c) = 0.2 * n(rng);
    const Matrix6d info = diagonalInformation(0.01, 0.002) + 100.0 * A * A.transpose();
    g.addEdge(i, i + 1, noisy(m.truth[i].inverse() * m.truth[i + 1], 0.01, 0.002), info);
  }
  for (int i = 0; i < g.numNodes(); i += 4) m.keyframes.push_back(i);
  const Matrix6d loop_info = diagonalInformation(0.02, 0.003);
  for (int i = lap; i < g.numNodes(); i += 8)
    g.addEdge(i - lap, i, noisy(m.truth[i - lap].inverse() * m.truth[i], 0.02, 0.003), loop_info, EdgeKind::Loop);
  for (int i = 8; i < g.numNodes(); i += 40)
    g.addEdge(i - 8, i, noisy(m.truth[i - 8].inverse() * m.truth[i], 0.01, 0.002), loop_info, EdgeKind::MapAnchor);
  for (int i = 0; i < g.numNodes(); i += 16)
    g.addGravityPrior(i, (m.truth[i].rotation().transpose() * Eigen::Vector3d(0, 0, -1)).normalized(), 0.01);
  initialiseFromOdometry(g);
  return m;
}

PoseGraphConfig asIs() {
  PoseGraphConfig c;
  c.init = PoseGraphInit::AsIs;
  return c;
}

// Folding a Gaussian chain is exact to first order: the keyframes' graph solved puts every
// keyframe within millimetres of where the whole graph's solve puts it, though both are
// decimetres from the truth and from the odometry.
TEST(KeyframeGraph, KeyframesLandWhereTheWholeGraphPutsThem) {
  const Mission m = makeMission(7);
  PoseGraph whole = m.graph;
  optimizePoseGraph(whole, asIs());
  std::optional<PoseGraph> keyframes = keyframeGraph(m.graph, m.keyframes);
  ASSERT_TRUE(keyframes.has_value());
  EXPECT_EQ(keyframes->numNodes(), static_cast<int>(m.keyframes.size()));
  EXPECT_EQ(keyframes->numEdges(), m.graph.numEdges() - (m.graph.numNodes() - 1) + keyframes->numNodes() - 1);
  EXPECT_EQ(keyframes->gravity_priors.size(), m.graph.gravity_priors.size());
  optimizePoseGraph(*keyframes, asIs());
  PoseGraph placed = m.graph;
  applyKeyframeSolution(placed, m.keyframes, *keyframes);
  double farthest_t = 0, farthest_r = 0, moved = 0, off_truth = 0;
  for (std::size_t j = 0; j < m.keyframes.size(); ++j) {
    const auto n = static_cast<std::size_t>(m.keyframes[j]);
    const Eigen::Isometry3d d = whole.poses[n].inverse() * placed.poses[n];
    farthest_t = std::max(farthest_t, translationNorm(d));
    farthest_r = std::max(farthest_r, rotationAngle(d));
    moved = std::max(moved, translationNorm(m.graph.poses[n].inverse() * whole.poses[n]));
    off_truth = std::max(off_truth, translationNorm(m.truth[n].inverse() * whole.poses[n]));
  }
  std::cout << "keyframes vs whole graph: " << 1e3 * farthest_t << " mm, " << farthest_r * 180 / M_PI
            << " deg; the solve moved them up to " << moved << " m; whole graph to truth up to " << off_truth << " m\n";
  EXPECT_GT(moved, 0.1);
  EXPECT_LT(farthest_t, 0.005);
  EXPECT_LT(farthest_r * 180 / M_PI, 0.02);
  EXPECT_LT((placed.gravity_world - whole.gravity_world).norm(), 1e-4);
}

// A frame between keyframes moves with the keyframe before it, rigidly; the folded edge's
// measurement is the increments composed, and its covariance the chained one.
TEST(KeyframeGraph, FramesBetweenMoveWithTheirKeyframeAndAFoldedEdgeIsTheChain) {
  PoseGraph g;
  const Eigen::Isometry3d a = fromXyzRpy(1.0, 0, 0, 0, 0, 0.1), b = fromXyzRpy(0.5, 0.2, 0, 0.02, 0, -0.3);
  g.addNode(Eigen::Isometry3d::Identity());
  g.addNode(a);
  g.addNode(a * b);
  g.addEdge(0, 1, a, diagonalInformation(0.1, 0.01));
  g.addEdge(1, 2, b, diagonalInformation(0.2, 0.02));
  const std::optional<PoseGraph> k = keyframeGraph(g, {0, 2});
  ASSERT_TRUE(k.has_value());
  ASSERT_EQ(k->numEdges(), 1);
  EXPECT_TRUE(k->edges[0].T_from_to.isApprox(a * b, 1e-12));
  const Matrix6d s1 = diagonalInformation(0.1, 0.01).inverse(), s2 = diagonalInformation(0.2, 0.02).inverse();
  const Matrix6d chained = s1 + adjoint(a) * s2 * adjoint(a).transpose();
  EXPECT_TRUE(k->edges[0].information.inverse().isApprox(chained, 1e-9));

  PoseGraph solved = *k;
  solved.poses[1] = fromXyzRpy(2.0, 1.0, 0, 0, 0, 0.5);
  PoseGraph placed = g;
  applyKeyframeSolution(placed, {0, 1}, PoseGraph{*keyframeGraph(g, {0, 1})});  // nothing moved
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(placed.poses[i].isApprox(g.poses[i], 1e-12));
  g.addNode(a * b * a);  // a frame after the last keyframe
  g.addEdge(2, 3, a, diagonalInformation(0.1, 0.01));
  placed = g;
  applyKeyframeSolution(placed, {0, 2}, solved);
  EXPECT_TRUE(placed.poses[1].isApprox(g.poses[1], 1e-12));  // moves with keyframe 0 (unmoved)
  EXPECT_TRUE(placed.poses[2].isApprox(solved.poses[1], 1e-12));
  EXPECT_TRUE((placed.poses[2].inverse() * placed.poses[3]).isApprox(g.poses[2].inverse() * g.poses[3], 1e-12));
  EXPECT_THROW(applyKeyframeSolution(placed, {0, 1, 2}, solved), Error);
}

// Only a chain folds: anything else is left to the whole graph's solve.
TEST(KeyframeGraph, WhatIsNotAKeyframeChainIsRefused) {
  const Mission m = makeMission(3);
  EXPECT_FALSE(keyframeGraph(m.graph, {4, 8}).has_value());  // the fixed node dropped
  EXPECT_FALSE(keyframeGraph(m.graph, {0, 8, 4}).has_value());  // not ascending
  EXPECT_FALSE(keyframeGraph(m.graph, {0, 1, 2, 3, 5}).has_value());  // a loop (240 → 480…) on a dropped node
  PoseGraph skip = m.graph;
  skip.addEdge(1, 3, Eigen::Isometry3d::Identity(), Matrix6d::Identity());  // odometry skipping a node
  EXPECT_FALSE(keyframeGraph(skip, m.keyframes).has_value());
  PoseGraph prior = m.graph;
  prior.addGravityPrior(5, Eigen::Vector3d(0, 0, -1), 0.01);
  EXPECT_FALSE(keyframeGraph(prior, m.keyframes).has_value());
  PoseGraph gap = m.graph;
  gap.edges.erase(gap.edges.begin() + 2);  // the link 2 → 3 missing
  EXPECT_FALSE(keyframeGraph(gap, m.keyframes).has_value());
  EXPECT_TRUE(keyframeGraph(m.graph, m.keyframes).has_value());
}

}  // namespace
}  // namespace hazmap
