// Edge NEES (eval/edge_nees.hpp): the convention (left perturbation, translation first) proven
// with sampled noise of a known covariance, the summaries, and `hazmap nees` / run.json on a run.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/eval/edge_nees.hpp"
#include "hazmap/graph/g2o.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

// A correlated, strongly anisotropic covariance (σx = 0.08 m, σy = 0.01 m, σyaw = 0.02 rad...).
Matrix6d knownCovariance() {
  Matrix6d L = Matrix6d::Zero();
  L.diagonal() << 0.08, 0.01, 0.02, 0.004, 0.006, 0.02;
  L(1, 0) = 0.005;
  L(5, 0) = 0.01;
  L(4, 2) = 0.003;
  L(3, 1) = -0.002;
  return L * L.transpose();
}

// True poses along a winding 3-D path: each step turns 50° in yaw and tilts a little, so the
// measurement frame and the world frame differ a lot (a wrong side shows).
std::vector<Eigen::Isometry3d> windingPath(int n) {
  std::vector<Eigen::Isometry3d> poses{Eigen::Isometry3d::Identity()};
  for (int i = 1; i < n; ++i)
    poses.push_back(poses.back() * fromXyzRpy(1.0, 0.3, 0.05, 0.1, -0.05, 0.87));
  return poses;
}

// A graph whose edge i→i+1 (and loops i→i+7) are the truth corrupted by ξ ~ N(0, Σ) on the left:
// T_true = exp(ξ)·T_measured, so T_measured = exp(−ξ)·T_true. Returns the sampled ξ per edge.
std::vector<Vector6d> sampledGraph(PoseGraph& g, const std::vector<Eigen::Isometry3d>& truth, const Matrix6d& cov,
                                   double loop_scale, std::uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  const Matrix6d L = cov.llt().matrixL();
  std::vector<Vector6d> xis;
  auto add = [&](int i, int j, EdgeKind kind, double scale) {
    Vector6d z;
    for (int k = 0; k < 6; ++k) z(k) = normal(rng);
    const Vector6d xi = scale * (L * z);
    const Eigen::Isometry3d T_true = truth[i].inverse() * truth[j];
    g.addEdge(i, j, se3Exp(-xi) * T_true, (scale * scale * cov).inverse(), kind);
    xis.push_back(xi);
  };
  for (const auto& T : truth) g.addNode(T);
  for (int i = 0; i + 1 < static_cast<int>(truth.size()); ++i) add(i, i + 1, EdgeKind::Odometry, 1.0);
  for (int i = 0; i + 7 < static_cast<int>(truth.size()); i += 3) add(i, i + 7, EdgeKind::Loop, loop_scale);
  return xis;
}

TEST(EdgeNees, RecoversTheSampledLeftPerturbationExactly) {
  const auto truth = windingPath(40);
  PoseGraph g;
  const auto xis = sampledGraph(g, truth, knownCovariance(), 1.0, 3);
  const EdgeNeesReport r = computeEdgeNees(g, truth);
  ASSERT_EQ(r.edges.size(), xis.size());
  for (std::size_t k = 0; k < xis.size(); ++k) {
    EXPECT_LT((r.edges[k].error - xis[k]).norm(), 1e-9) << k;
    EXPECT_NEAR(r.edges[k].nees, xis[k].dot(g.edges[k].information * xis[k]), 1e-9);
  }
}

TEST(EdgeNees, HonestCovarianceGivesChiSquareSix) {
  const auto truth = windingPath(3001);
  PoseGraph g;
  sampledGraph(g, truth, knownCovariance(), 1.0, 7);
  const EdgeNeesReport r = computeEdgeNees(g, truth);
  ASSERT_EQ(r.odometry.count, 3000u);
  ASSERT_EQ(r.loop.count, 998u);
  // χ²(6): mean 6 (sd of a mean of 3000 ≈ 0.063), median 5.35, 95 % below 12.59.
  EXPECT_NEAR(r.odometry.mean, 6.0, 0.3);
  EXPECT_NEAR(r.odometry.median, 5.35, 0.3);
  EXPECT_NEAR(r.odometry.p95, 12.59, 0.8);
  EXPECT_NEAR(r.odometry.within_95, 0.95, 0.015);
  for (double a : r.odometry.axis_mean) EXPECT_NEAR(a, 1.0, 0.1);
  EXPECT_NEAR(r.loop.mean, 6.0, 0.5);
  EXPECT_EQ(r.all.count, r.odometry.count + r.loop.count + r.map_anchor.count);
  EXPECT_EQ(r.odometry.dof, 6);
}

TEST(EdgeNees, FlagsOverAndUnderConfidentEdges) {
  // Loop edges whose true noise is 3× what their information says: NEES ≈ 9 · 6.
  const auto truth = windingPath(1201);
  PoseGraph g;
  sampledGraph(g, truth, knownCovariance(), 1.0, 11);
  for (auto& e : g.edges)
    if (e.kind == EdgeKind::Loop) e.information *= 9.0;
  const EdgeNeesReport r = computeEdgeNees(g, truth);
  EXPECT_NEAR(r.odometry.mean, 6.0, 0.5);
  EXPECT_NEAR(r.loop.mean, 54.0, 6.0);
  EXPECT_LT(r.loop.within_95, 0.5);
}

TEST(EdgeNees, TheRightSideErrorWithLeftInformationIsInconsistent) {
  // The same honest samples read with the other convention, Log(T̃⁻¹·T_true) (a right
  // perturbation), weighted by the left information: far from 6 on a path that turns. This is
  // what makes the first two tests able to fail on a wrong side.
  const auto truth = windingPath(2001);
  PoseGraph g;
  sampledGraph(g, truth, knownCovariance(), 1.0, 5);
  double sum = 0;
  std::size_t n = 0;
  for (const auto& e : g.edges) {
    if (e.kind != EdgeKind::Odometry) continue;
    const Eigen::Isometry3d T_true = truth[e.from].inverse() * truth[e.to];
    const Vector6d wrong = se3Log(e.T_from_to.inverse() * T_true);
    sum += wrong.dot(e.information * wrong);
    ++n;
  }
  EXPECT_GT(sum / static_cast<double>(n), 12.0);
  // ...while the g2o (right-perturbation) information matches that side: the conversion and the
  // convention agree.
  double right = 0;
  for (const auto& e : g.edges) {
    if (e.kind != EdgeKind::Odometry) continue;
    const Eigen::Isometry3d T_true = truth[e.from].inverse() * truth[e.to];
    const Vector6d xi_r = se3Log(e.T_from_to.inverse() * T_true);
    right += xi_r.dot(informationLeftToRight(e.T_from_to, e.information) * xi_r);
  }
  EXPECT_NEAR(right / static_cast<double>(n), 6.0, 0.4);
}

TEST(EdgeNees, PlanarGraphsUseThreeDegreesOfFreedom) {
  PoseGraph g;
  g.dimension = 2;
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < 2001; ++i) truth.push_back(fromXyYaw(0.5 * i, 0.1 * i, 0.3 * i));
  for (const auto& T : truth) g.addNode(T);
  std::mt19937_64 rng(2);
  std::normal_distribution<double> normal;
  Matrix6d info = Matrix6d::Identity();
  const double sx = 0.05, sy = 0.02, st = 0.01;
  info(0, 0) = 1 / (sx * sx);
  info(1, 1) = 1 / (sy * sy);
  info(5, 5) = 1 / (st * st);
  for (int i = 0; i + 1 < 2001; ++i) {
    Vector6d xi = Vector6d::Zero();
    xi(0) = sx * normal(rng);
    xi(1) = sy * normal(rng);
    xi(5) = st * normal(rng);
    g.addEdge(i, i + 1, se3Exp(-xi) * truth[i].inverse() * truth[i + 1], info);
  }
  const EdgeNeesReport r = computeEdgeNees(g, truth);
  EXPECT_EQ(r.odometry.dof, 3);
  EXPECT_NEAR(r.odometry.mean, 3.0, 0.2);
  EXPECT_EQ(r.loop.count, 0u);
  EXPECT_EQ(r.loop.mean, 0.0);
}

TEST(EdgeNees, RejectsMismatchedTruth) {
  const auto truth = windingPath(5);
  PoseGraph g;
  sampledGraph(g, truth, knownCovariance(), 1.0, 1);
  EXPECT_THROW(computeEdgeNees(g, windingPath(4)), Error);
  auto bad = truth;
  bad[2].translation().x() = std::nan("");
  EXPECT_THROW(computeEdgeNees(g, bad), Error);
}

TEST(EdgeNees, JsonHasTheSummariesAndOptionallyTheEdges) {
  const auto truth = windingPath(20);
  PoseGraph g;
  sampledGraph(g, truth, knownCovariance(), 1.0, 4);
  const EdgeNeesReport r = computeEdgeNees(g, truth);
  const auto j = nlohmann::json::parse(toJson(r));
  EXPECT_EQ(j.at("odometry").at("count").get<std::size_t>(), 19u);
  EXPECT_DOUBLE_EQ(j.at("loop").at("mean").get<double>(), r.loop.mean);
  EXPECT_FALSE(j.contains("edges"));
  const auto je = nlohmann::json::parse(toJson(r, true));
  ASSERT_EQ(je.at("edges").size(), r.edges.size());
  EXPECT_EQ(je.at("edges")[0].at("kind"), "odometry");
  EXPECT_NE(toText(r).find("odometry"), std::string::npos);
}

nlohmann::json parseJson(const std::string& text) { return nlohmann::json::parse(text); }

// A real run: run.json carries the NEES of its graph, and `hazmap nees` on the folder (the graph
// read back from graph.g2o, the truth from the sequence run.json names) gives the same figures.
TEST(EdgeNeesCli, RunFolderAndRunJsonAgree) {
  const auto seq = test::writeSimulatedSequence("nees", "corridor", 1, 14);
  const auto out = test::scratchDir();
  auto r = test::runCli("run " + seq.string() + " --method icp+pgo --quiet --no-viewer --out " + (out / "run").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto run_json = parseJson(readTextFile(out / "run" / "run.json"));
  const auto& in_run = run_json.at("edge_nees");
  EXPECT_EQ(in_run.at("odometry").at("count").get<std::size_t>(), 13u);
  const double mean = in_run.at("odometry").at("mean").get<double>();
  EXPECT_TRUE(std::isfinite(mean));
  EXPECT_GT(mean, 0.0);
  r = test::runCli("nees " + (out / "run").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto cli = parseJson(r.output);
  EXPECT_EQ(cli.at("odometry").at("count"), in_run.at("odometry").at("count"));
  EXPECT_NEAR(cli.at("odometry").at("mean").get<double>(), mean, 1e-6 * mean);
  r = test::runCli("nees --graph " + (out / "run" / "graph.g2o").string() + " --gt " + (seq / "poses.txt").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("odometry"), std::string::npos);
  // Bad input: a graph without truth, truth of the wrong length, a folder without a graph.
  r = test::runCli("nees --graph " + (out / "run" / "graph.g2o").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--gt"), std::string::npos) << r.output;
  writeTextAtomically(out / "short.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  r = test::runCli("nees " + (out / "run").string() + " --gt " + (out / "short.txt").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("1 true poses for a graph of 14 nodes"), std::string::npos) << r.output;
  r = test::runCli("nees " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("graph.g2o: does not exist"), std::string::npos) << r.output;
  std::filesystem::remove_all(out);
  std::filesystem::remove_all(seq);
}

// Span NEES (odometrySpanNees): increments chained as independent. Ten unit steps along x whose
// errors are all +1 cm (fully correlated) against a per-step σ of 1 cm: each edge has NEES 1, a
// span of 10 has error 10 cm against σ √10 cm, NEES 10.
TEST(SpanNees, CorrelatedIncrementErrorsGrowWithTheSpan) {
  PoseGraph g;
  std::vector<Eigen::Isometry3d> truth;
  Matrix6d cov = Matrix6d::Identity() * 1e-4;
  for (int i = 0; i <= 10; ++i) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().x() = 1.01 * i;
    truth.push_back(T);
    g.addNode(Eigen::Isometry3d::Identity());
  }
  Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
  step.translation().x() = 1.0;
  for (int i = 0; i < 10; ++i) g.addEdge(i, i + 1, step, cov.inverse());
  EXPECT_NEAR(odometrySpanNees(g, truth, 1).mean, 1.0, 1e-6);
  const NeesStats ten = odometrySpanNees(g, truth, 10);
  EXPECT_EQ(ten.count, 1u);
  EXPECT_NEAR(ten.mean, 10.0, 1e-6);
}

}  // namespace
}  // namespace hazmap
