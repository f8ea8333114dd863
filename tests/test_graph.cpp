// Pose graph: residual Jacobians, costs, chordal initialisation, g2o IO and its errors, the
// optimiser on the small grids, robust loss against wrong loop edges, the CLI.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "graph/residuals.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/graph/chordal_init.hpp"
#include "hazmap/graph/costs.hpp"
#include "hazmap/graph/optimizer.hpp"
#include "hazmap/graph/g2o.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using test::sharedData;

Eigen::Isometry3d randomPose(std::mt19937& rng, double t_scale, double r_scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int k = 0; k < 3; ++k) xi(k) = t_scale * n(rng);
  for (int k = 3; k < 6; ++k) xi(k) = r_scale * n(rng);
  return se3Exp(xi);
}

Matrix6d randomInformation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Matrix6d A;
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) A(r, c) = n(rng);
  return A * A.transpose() + 2.0 * Matrix6d::Identity();
}

double ate(const std::vector<Eigen::Isometry3d>& estimate,
           const std::vector<Eigen::Isometry3d>& truth) {
  Eigen::Matrix3Xd src(3, estimate.size()), dst(3, truth.size());
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    src.col(i) = estimate[i].translation();
    dst.col(i) = truth[i].translation();
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  const Eigen::Matrix3Xd aligned =
      (T.topLeftCorner<3, 3>() * src).colwise() + T.topRightCorner<3, 1>();
  return std::sqrt((aligned - dst).colwise().squaredNorm().mean());
}

// ---------------------------------------------------------------------------------------------
// Analytic Jacobians against central differences through the manifold.

template <int R, int P>
void checkJacobians(const ceres::CostFunction& f, std::vector<std::vector<double>> params,
                    int tangent, const std::function<void(const double*, const double*, double*)>&
                                     plus) {
  std::vector<const double*> ptrs = {params[0].data(), params[1].data()};
  Eigen::Matrix<double, R, 1> r0;
  std::vector<Eigen::Matrix<double, R, P, Eigen::RowMajor>> J(2);
  double* jac[2] = {J[0].data(), J[1].data()};
  ASSERT_TRUE(f.Evaluate(ptrs.data(), r0.data(), jac));
  const double h = 1e-6;
  for (int b = 0; b < 2; ++b) {
    for (int k = 0; k < tangent; ++k) {
      std::vector<double> delta(tangent, 0.0);
      auto p_plus = params, p_minus = params;
      delta[k] = h;
      plus(params[b].data(), delta.data(), p_plus[b].data());
      delta[k] = -h;
      plus(params[b].data(), delta.data(), p_minus[b].data());
      Eigen::Matrix<double, R, 1> rp, rm;
      std::vector<const double*> pp = {p_plus[0].data(), p_plus[1].data()};
      std::vector<const double*> pm = {p_minus[0].data(), p_minus[1].data()};
      f.Evaluate(pp.data(), rp.data(), nullptr);
      f.Evaluate(pm.data(), rm.data(), nullptr);
      const Eigen::Matrix<double, R, 1> numeric = (rp - rm) / (2 * h);
      const Eigen::Matrix<double, R, 1> analytic = J[b].col(k);
      EXPECT_LT((numeric - analytic).norm(), 1e-5 * (1.0 + numeric.norm()))
          << "block " << b << " tangent " << k << "\nnumeric " << numeric.transpose()
          << "\nanalytic " << analytic.transpose();
    }
  }
}

std::vector<double> block3(const Eigen::Isometry3d& T) {
  std::vector<double> p(12);
  Eigen::Map<Eigen::Vector3d>{p.data()} = T.translation();
  Eigen::Map<Eigen::Matrix3d>{p.data() + 3} = T.linear();
  return p;
}

TEST(GraphResiduals, AnalyticJacobiansMatchNumeric3D) {
  std::mt19937 rng(7);
  graph_detail::PoseManifold3 manifold;
  auto plus = [&](const double* x, const double* d, double* out) { manifold.Plus(x, d, out); };
  for (int trial = 0; trial < 5; ++trial) {
    const Eigen::Isometry3d Ti = randomPose(rng, 3.0, 1.0);
    const Eigen::Isometry3d meas = randomPose(rng, 1.0, 0.5);
    const Eigen::Isometry3d Tj = Ti * meas * randomPose(rng, 0.2, 0.3);  // non-zero error
    const Matrix6d L = Eigen::LLT<Matrix6d>(randomInformation(rng)).matrixU();
    graph_detail::GeodesicCost3 geo(meas.linear(), meas.translation(), L);
    checkJacobians<6, 12>(geo, {block3(Ti), block3(Tj)}, 6, plus);
    graph_detail::ChordalCost3 cho(meas.linear(), meas.translation(), 2.5, 7.0);
    checkJacobians<6, 12>(cho, {block3(Ti), block3(Tj)}, 6, plus);
  }
}

TEST(GraphResiduals, AnalyticJacobiansMatchNumeric2D) {
  std::mt19937 rng(8);
  std::normal_distribution<double> n(0.0, 1.0);
  auto plus = [](const double* x, const double* d, double* out) {
    for (int k = 0; k < 3; ++k) out[k] = x[k] + d[k];
  };
  for (int trial = 0; trial < 5; ++trial) {
    std::vector<double> pi = {n(rng), n(rng), n(rng)}, pj = {n(rng), n(rng), n(rng)};
    Eigen::Matrix3d A = Eigen::Matrix3d::Random();
    const Eigen::Matrix3d L =
        Eigen::LLT<Eigen::Matrix3d>(A * A.transpose() + Eigen::Matrix3d::Identity()).matrixU();
    graph_detail::GeodesicCost2 geo(0.5, -0.2, 0.3, L);
    checkJacobians<3, 3>(geo, {pi, pj}, 3, plus);
    graph_detail::ChordalCost2 cho(0.5, -0.2, 0.3, 3.0, 5.0);
    checkJacobians<3, 3>(cho, {pi, pj}, 3, plus);
  }
}

// ---------------------------------------------------------------------------------------------
// Costs.

TEST(GraphCosts, ChordalResidualFormEqualsSeSyncDefinition) {
  // The optimiser's 6-residual chordal form must give exactly κ‖R_j − R_iR̃‖² + τ‖…‖².
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const Eigen::Isometry3d Ti = randomPose(rng, 2.0, 1.5), Tj = randomPose(rng, 2.0, 1.5);
    const Eigen::Isometry3d meas = randomPose(rng, 1.0, 1.0);
    const double kappa = 4.0, tau = 9.0;
    graph_detail::ChordalCost3 f(meas.linear(), meas.translation(), kappa, tau);
    auto bi = block3(Ti), bj = block3(Tj);
    const double* p[2] = {bi.data(), bj.data()};
    Eigen::Matrix<double, 6, 1> r;
    f.Evaluate(p, r.data(), nullptr);
    const double direct =
        kappa * (Tj.linear() - Ti.linear() * meas.linear()).squaredNorm() +
        tau * (Tj.translation() - Ti.translation() - Ti.linear() * meas.translation())
                  .squaredNorm();
    EXPECT_NEAR(r.squaredNorm(), direct, 1e-9 * direct);
  }
}

TEST(GraphCosts, ChordalWeightsFollowSeSync) {
  PoseGraph g;
  g.addNode(Eigen::Isometry3d::Identity());
  g.addNode(fromXyzRpy(1, 0, 0, 0, 0, 0.3));
  Matrix6d info = Matrix6d::Zero();
  info.diagonal() << 10, 20, 40, 100, 200, 400;
  // A pure rotation measurement: left and right information coincide in the translation block.
  const Eigen::Isometry3d meas = fromXyzRpy(0, 0, 0, 0.1, 0.2, 0.3);
  g.addEdge(0, 1, meas, informationRightToLeft(meas, info));
  const ChordalWeights w = chordalWeights(g.edges[0], 3);
  EXPECT_NEAR(w.tau, 3.0 / (1 / 10.0 + 1 / 20.0 + 1 / 40.0), 1e-9);
  EXPECT_NEAR(w.kappa, 3.0 / (2.0 * (1 / 100.0 + 1 / 200.0 + 1 / 400.0)), 1e-9);
}

TEST(GraphCosts, LeftRightInformationRoundTripAndInvariance) {
  std::mt19937 rng(11);
  const Eigen::Isometry3d T = randomPose(rng, 2.0, 1.0);
  const Matrix6d right = randomInformation(rng);
  const Matrix6d back = informationLeftToRight(T, informationRightToLeft(T, right));
  EXPECT_LT((back - right).norm(), 1e-9 * right.norm());
  // A small error expressed on the right and on the left has the same cost.
  Vector6d xi_r;
  xi_r << 0.01, -0.02, 0.005, 0.003, -0.001, 0.002;
  const Vector6d xi_l = adjoint(T) * xi_r;  // T exp(ξ_r) = exp(Ad ξ_r) T
  EXPECT_NEAR(xi_r.dot(right * xi_r), xi_l.dot(informationRightToLeft(T, right) * xi_l), 1e-12);
}

TEST(GraphCosts, ZeroOnConsistentGraphAndKnownValueOnPerturbed) {
  PoseGraph g;
  g.addNode(Eigen::Isometry3d::Identity());
  g.addNode(fromXyzRpy(1, 2, 3, 0.1, 0.2, 0.3));
  // Identity information in the measurement frame (what a g2o file would hold).
  g.addEdge(0, 1, g.poses[1], informationRightToLeft(g.poses[1], Matrix6d::Identity()));
  EXPECT_NEAR(geodesicCost(g), 0.0, 1e-20);
  EXPECT_NEAR(chordalCost(g), 0.0, 1e-20);
  // Rotate node 1 by θ about its own z: geodesic = θ² (unit info), chordal = κ·4(1 − cos θ).
  const double theta = 0.2;
  g.poses[1] = g.poses[1] * fromXyzRpy(0, 0, 0, 0, 0, theta);
  EXPECT_NEAR(geodesicCost(g), theta * theta, 1e-12);
  EXPECT_NEAR(chordalCost(g), 0.5 * 4.0 * (1.0 - std::cos(theta)), 1e-12);  // κ = 3/(2·3) = ½
}

// ---------------------------------------------------------------------------------------------
// Chordal initialisation.

TEST(GraphChordalInit, RecoversNoiseFreePosesExactly) {
  std::mt19937 rng(5);
  PoseGraph g;
  std::vector<Eigen::Isometry3d> truth;
  for (int i = 0; i < 30; ++i) {
    truth.push_back(i == 0 ? Eigen::Isometry3d::Identity() : randomPose(rng, 5.0, 2.0));
    g.addNode(Eigen::Isometry3d::Identity());
  }
  for (int i = 0; i + 1 < 30; ++i)
    g.addEdge(i, i + 1, truth[i].inverse() * truth[i + 1], randomInformation(rng));
  for (int k = 0; k < 20; ++k) {
    const int i = rng() % 30, j = rng() % 30;
    if (i != j)
      g.addEdge(i, j, truth[i].inverse() * truth[j], randomInformation(rng), EdgeKind::Loop);
  }
  chordalInitialisation(g);
  for (int i = 0; i < 30; ++i) {
    EXPECT_LT((g.poses[i].matrix() - truth[i].matrix()).norm(), 1e-8) << "node " << i;
  }
}

TEST(GraphChordalInit, DisconnectedGraphIsReported) {
  PoseGraph g;
  for (int i = 0; i < 4; ++i) g.addNode(Eigen::Isometry3d::Identity());
  g.addEdge(0, 1, Eigen::Isometry3d::Identity(), Matrix6d::Identity());
  g.addEdge(2, 3, Eigen::Isometry3d::Identity(), Matrix6d::Identity());
  try {
    optimizePoseGraph(g);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("disconnected: 2 components"), std::string::npos)
        << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// g2o files.

std::string errorOf(const std::string& text) {
  try {
    parseG2o(text, "bad.g2o");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(GraphG2o, MalformedLinesGiveLineNumbers) {
  const std::string v0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n";
  const std::string v1 = "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n";
  const std::string info = " 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string e01 = "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1" + info + "\n";
  EXPECT_EQ(parseG2o(v0 + v1 + e01, "ok.g2o").numEdges(), 1);
  EXPECT_EQ(errorOf(v0 + "VERTEX_SE3:QUAT 1 1 0 0 0 0 1\n"),
            "bad.g2o:2: VERTEX_SE3:QUAT needs 9 tokens, found 8");
  EXPECT_EQ(errorOf(v0 + v1 + "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 2\n"),
            "bad.g2o:3: EDGE_SE3:QUAT needs 31 tokens, found 12");
  EXPECT_EQ(errorOf(v0 + "VERTEX_XYZ 1 1 0 0\n"), "bad.g2o:2: unknown tag 'VERTEX_XYZ'");
  EXPECT_EQ(errorOf(v0 + "VERTEX_SE3:QUAT 1 nan 0 0 0 0 0 1\n"),
            "bad.g2o:2: non-finite value 'nan' (NaN or inf)");
  EXPECT_EQ(errorOf(v0 + v1 + "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 -1 "
                              "0 0 1 0 1\n"),
            "bad.g2o:3: information matrix is not positive definite");
  EXPECT_EQ(errorOf(v0 + v1 + "EDGE_SE3:QUAT 0 7 1 0 0 0 0 0 1" + info + "\n"),
            "bad.g2o:3: edge to missing vertex 7");
  EXPECT_EQ(errorOf(v0 + v0), "bad.g2o:2: duplicate vertex id 0 (first on line 1)");
  EXPECT_EQ(errorOf(v0 + "VERTEX_SE2 1 0 0 0\n"), "bad.g2o:2: mixes 2-D and 3-D vertices/edges");
  EXPECT_EQ(errorOf(v0 + "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 0\n"), "bad.g2o:2: quaternion has zero norm");
  EXPECT_EQ(errorOf("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 0\n"),
            "bad.g2o:1: information matrix is not positive definite");
  EXPECT_EQ(errorOf("# only a comment\n"), "bad.g2o: no vertices or edges (not a g2o pose graph)");
  EXPECT_THROW(readG2o("/nonexistent/graph.g2o"), Error);
}

TEST(GraphG2o, RoundTrip3DIsExact) {
  const PoseGraph g = readG2o(sharedData("pose-graphs/smallGrid3D.g2o"));
  ASSERT_EQ(g.numNodes(), 125);
  ASSERT_EQ(g.numEdges(), 297);
  const auto dir = test::scratchDir();
  writeG2o(dir / "out.g2o", g);
  const PoseGraph h = readG2o(dir / "out.g2o");
  ASSERT_EQ(h.numNodes(), g.numNodes());
  ASSERT_EQ(h.numEdges(), g.numEdges());
  for (int i = 0; i < g.numNodes(); ++i) {
    EXPECT_EQ(h.ids[i], g.ids[i]);
    EXPECT_LT((h.poses[i].matrix() - g.poses[i].matrix()).norm(), 1e-12);
  }
  for (int k = 0; k < g.numEdges(); ++k) {
    EXPECT_EQ(h.edges[k].kind, g.edges[k].kind);
    EXPECT_LT((h.edges[k].information - g.edges[k].information).norm(),
              1e-9 * g.edges[k].information.norm());
  }
  EXPECT_NEAR(chordalCost(h), chordalCost(g), 1e-9 * chordalCost(g));
  // The file's information is the right-perturbation one: the first edge reads back as written.
  const Matrix6d right = informationLeftToRight(g.edges[0].T_from_to, g.edges[0].information);
  EXPECT_NEAR(right(0, 0), 100.0, 1e-9);  // smallGrid3D: diag(100, 100, 100, 25, 25, 25)
  EXPECT_NEAR(right(3, 3), 25.0, 1e-9);
  EXPECT_NEAR(right(0, 5), 0.0, 1e-9);
  EXPECT_GT(std::abs(g.edges[0].information(0, 5)), 1.0);  // the stored left form differs
}

TEST(GraphG2o, FileWithoutVerticesComposesOdometry2D) {
  G2oReadInfo info;
  const PoseGraph g = readG2o(sharedData("pose-graphs/CSAIL.g2o"), &info);
  EXPECT_FALSE(info.had_vertices);
  EXPECT_EQ(g.dimension, 2);
  EXPECT_EQ(g.numNodes(), 1045);
  EXPECT_EQ(g.numEdges(), 1172);
  // Node 2 = composition of the first two odometry edges (x y θ from the file).
  const Eigen::Isometry3d expected =
      fromXyYaw(0.082760, 0.003050, 0.284020) * fromXyYaw(0.091720, 0.004550, 0.270090);
  EXPECT_LT((g.poses[2].matrix() - expected.matrix()).norm(), 1e-12);
  // Every 2-D pose stays in the plane.
  for (const auto& T : g.poses) EXPECT_NEAR(T.translation().z(), 0.0, 0.0);
}

// ---------------------------------------------------------------------------------------------
// Optimiser on the small grids.

TEST(GraphOptimizer, SmallGridsReachTheSameOptimumFromEveryStart) {
  for (const char* name : {"tinyGrid3D", "smallGrid3D"}) {
    SCOPED_TRACE(name);
    const PoseGraph original = readG2o(sharedData(std::string("pose-graphs/") + name + ".g2o"));
    double F[3], chi2[3];
    const PoseGraphInit inits[3] = {PoseGraphInit::AsIs, PoseGraphInit::Odometry,
                                    PoseGraphInit::Chordal};
    for (int k = 0; k < 3; ++k) {
      PoseGraph g = original;
      PoseGraphConfig c;
      c.cost = PoseGraphCost::Chordal;
      c.init = inits[k];
      c.loop_loss = LoopLoss::None;
      c.function_tolerance = 1e-10;
      const PoseGraphReport r = optimizePoseGraph(g, c);
      F[k] = r.final_chordal;
      EXPECT_LT(r.final_chordal, r.initial_chordal);
      EXPECT_NEAR(r.final_chordal, chordalCost(g), 1e-9 * r.final_chordal);
      PoseGraphConfig geo = c;
      geo.cost = PoseGraphCost::Geodesic;
      geo.init = PoseGraphInit::AsIs;
      chi2[k] = optimizePoseGraph(g, geo).final_geodesic;
      EXPECT_EQ(g.poses[0].matrix(), original.poses[0].matrix());  // fixed node untouched
    }
    for (int k = 1; k < 3; ++k) {
      EXPECT_NEAR(F[k], F[0], 1e-5 * F[0]);
      EXPECT_NEAR(chi2[k], chi2[0], 1e-5 * chi2[0]);
    }
    // The two costs agree to first order at the optimum (small noise): χ² within 5 % of F.
    EXPECT_NEAR(chi2[0], F[0], 0.05 * F[0]);
  }
}

TEST(GraphOptimizer, OptimumIsStationaryUnderPerturbation) {
  PoseGraph g = readG2o(sharedData("pose-graphs/smallGrid3D.g2o"));
  PoseGraphConfig c;
  c.cost = PoseGraphCost::Geodesic;
  c.loop_loss = LoopLoss::None;
  c.function_tolerance = 1e-12;
  c.gradient_tolerance = 1e-14;
  c.parameter_tolerance = 1e-14;
  optimizePoseGraph(g, c);
  const double best = geodesicCost(g);
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    PoseGraph h = g;
    const int i = 1 + rng() % (g.numNodes() - 1);
    h.poses[i] = h.poses[i] * randomPose(rng, 1e-3, 1e-3);
    EXPECT_GE(geodesicCost(h), best - 1e-9 * best);
  }
}

TEST(GraphOptimizer, TwoDimensionalGraphStaysPlanarAndReachesPublishedOptimum) {
  // CSAIL: F* = 31.70 (SE-Sync). Files without vertices start from the chordal solution.
  PoseGraph g = readG2o(sharedData("pose-graphs/CSAIL.g2o"));
  PoseGraphConfig c;
  c.cost = PoseGraphCost::Chordal;
  c.init = PoseGraphInit::Chordal;
  c.loop_loss = LoopLoss::None;
  const PoseGraphReport r = optimizePoseGraph(g, c);
  EXPECT_LT(std::abs(r.final_chordal - 31.70) / 31.70, 1e-3) << r.final_chordal;
  for (const auto& T : g.poses) {
    EXPECT_EQ(T.translation().z(), 0.0);
    EXPECT_NEAR(std::abs(T.linear()(2, 2)), 1.0, 1e-12);
  }
}

TEST(GraphOptimizer, InvalidConfigIsRejected) {
  PoseGraph g = readG2o(sharedData("pose-graphs/tinyGrid3D.g2o"));
  PoseGraphConfig c;
  c.threads = 0;
  EXPECT_THROW(optimizePoseGraph(g, c), Error);
  c = {};
  c.loop_loss_scale = -1;
  EXPECT_THROW(optimizePoseGraph(g, c), Error);
  EXPECT_THROW(parsePoseGraphCost("euclid"), Error);
  EXPECT_THROW(parseLoopLoss("huber"), Error);
}

TEST(GraphOptimizer, YamlConfig) {
  const auto dir = test::scratchDir();
  std::ofstream(dir / "c.yaml") << "graph:\n  cost: chordal\n  init: odometry\n  loop_loss: dcs\n"
                                   "  loop_loss_scale: 2.5\n  threads: 2\n";
  const PoseGraphConfig c = loadPoseGraphConfig(dir / "c.yaml");
  EXPECT_EQ(c.cost, PoseGraphCost::Chordal);
  EXPECT_EQ(c.init, PoseGraphInit::Odometry);
  EXPECT_EQ(c.loop_loss, LoopLoss::Dcs);
  EXPECT_EQ(c.loop_loss_scale, 2.5);
  EXPECT_EQ(c.threads, 2);
  std::ofstream(dir / "bad.yaml") << "graph:\n  cots: chordal\n";
  try {
    loadPoseGraphConfig(dir / "bad.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("graph: unknown key 'cots' (did you mean 'cost'?)"), std::string::npos);
  }
}

// ---------------------------------------------------------------------------------------------
// Robust loss: wrong loop edges must not harm the optimised trajectory.

struct Scenario {
  std::vector<Eigen::Isometry3d> truth;
  PoseGraph graph;
};

/// Three laps of a 20 m × 10 m rectangle (1 m steps, slowly climbing), noisy odometry, correct
/// loop edges every 4th node to the same place on earlier laps.
Scenario makeScenario(int wrong_loops, std::uint32_t seed) {
  std::mt19937 rng(seed);
  Scenario s;
  const int lap = 60;
  s.truth = test::rectangleLaps(3, 1.0, 0.02);
  const double st = 0.05, sr = 0.01;
  Matrix6d info = Matrix6d::Zero();
  info.diagonal() << 1 / (st * st), 1 / (st * st), 1 / (st * st), 1 / (sr * sr), 1 / (sr * sr),
      1 / (sr * sr);
  PoseGraph& g = s.graph;
  for (std::size_t i = 0; i < s.truth.size(); ++i) g.addNode(Eigen::Isometry3d::Identity());
  std::normal_distribution<double> n(0.0, 1.0);
  auto noisy = [&](const Eigen::Isometry3d& T) {
    Vector6d xi;
    for (int k = 0; k < 3; ++k) xi(k) = st * n(rng);
    for (int k = 3; k < 6; ++k) xi(k) = sr * n(rng);
    return se3Exp(xi) * T;  // left perturbation, as the information says
  };
  for (int i = 0; i + 1 < g.numNodes(); ++i)
    g.addEdge(i, i + 1, noisy(s.truth[i].inverse() * s.truth[i + 1]), info);
  for (int i = lap; i < g.numNodes(); i += 4)
    g.addEdge(i - lap, i, noisy(s.truth[i - lap].inverse() * s.truth[i]), info, EdgeKind::Loop);
  // Wrong loops: places across the rectangle claimed to be the same (identity), as confident as
  // the correct ones — what a perceptual-aliasing false positive looks like.
  for (int k = 0; k < wrong_loops; ++k) {
    const int i = 5 + static_cast<int>(rng() % (g.numNodes() - 40));
    const int j = i + 25 + static_cast<int>(rng() % 10);
    g.addEdge(i, j, Eigen::Isometry3d::Identity(), info, EdgeKind::Loop);
  }
  initialiseFromOdometry(g);
  return s;
}

double optimisedAte(Scenario s, LoopLoss loss) {
  PoseGraphConfig c;
  c.loop_loss = loss;
  c.init = PoseGraphInit::AsIs;
  optimizePoseGraph(s.graph, c);
  return ate(s.graph.poses, s.truth);
}

TEST(GraphOptimizer, RobustLossKeepsTrajectoryUnharmedByWrongLoops) {
  const Scenario clean = makeScenario(0, 42);
  const Scenario dirty = makeScenario(8, 42);  // same noise, plus 8 wrong loop edges
  const double ate_odometry = ate(clean.graph.poses, clean.truth);
  const double ate_clean = optimisedAte(clean, LoopLoss::None);
  const double ate_plain = optimisedAte(dirty, LoopLoss::None);
  const double ate_cauchy = optimisedAte(dirty, LoopLoss::Cauchy);
  const double ate_dcs = optimisedAte(dirty, LoopLoss::Dcs);
  std::printf("ATE odometry %.3f, clean %.3f, wrong loops: none %.3f cauchy %.3f dcs %.3f m\n",
              ate_odometry, ate_clean, ate_plain, ate_cauchy, ate_dcs);
  EXPECT_LT(ate_clean, 0.5 * ate_odometry);   // loop closure helps
  EXPECT_GT(ate_plain, 5.0 * ate_clean);      // wrong loops without a robust loss do harm
  EXPECT_LT(ate_cauchy, 1.2 * ate_clean + 0.01);
  EXPECT_LT(ate_dcs, 1.2 * ate_clean + 0.01);
}

// ---------------------------------------------------------------------------------------------
// CLI.

TEST(GraphCli, OptimizePrintsBothCostsAndWritesGraph) {
  const auto dir = test::scratchDir();
  const auto out = dir / "opt.g2o";
  const auto r = test::runCli("graph optimize " + sharedData("pose-graphs/smallGrid3D.g2o").string() +
                              " --out " + out.string() + " --cost chordal --init chordal");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("chordal "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("geodesic "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("iterations: "), std::string::npos) << r.output;
  const PoseGraph g = readG2o(out);
  EXPECT_EQ(g.numNodes(), 125);
  // The written graph is the optimum: optimising it again barely changes the cost.
  PoseGraph h = g;
  PoseGraphConfig c;
  c.cost = PoseGraphCost::Chordal;
  c.loop_loss = LoopLoss::None;
  const auto rep = optimizePoseGraph(h, c);
  EXPECT_LT(rep.initial_chordal - rep.final_chordal, 1e-4 * rep.initial_chordal);
}

TEST(GraphCli, YamlConfigIsUsedAndFlagsOverrideIt) {
  const auto dir = test::scratchDir();
  std::ofstream(dir / "c.yaml") << "graph:\n  cost: chordal\n  init: odometry\n  loop_loss: dcs\n";
  const std::string in = sharedData("pose-graphs/tinyGrid3D.g2o").string();
  const auto r = test::runCli("graph optimize " + in + " --config " + (dir / "c.yaml").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("cost: chordal, init: odometry, loop loss: dcs"), std::string::npos)
      << r.output;
  const auto o = test::runCli("graph optimize " + in + " --config " + (dir / "c.yaml").string() +
                              " --init chordal --cost geodesic");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("cost: geodesic, init: chordal, loop loss: dcs"), std::string::npos)
      << o.output;
}

TEST(GraphCli, BadInputGivesOneLineErrorAndNoOutput) {
  const auto dir = test::scratchDir();
  std::ofstream(dir / "bad.g2o") << "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 0 0\n";
  const auto r = test::runCli("graph optimize " + (dir / "bad.g2o").string() + " --out " +
                              (dir / "out.g2o").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("bad.g2o:2: VERTEX_SE3:QUAT needs 9 tokens, found 4"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "out.g2o"));
  std::ofstream(dir / "split.g2o") << "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
                                      "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  const auto d = test::runCli("graph optimize " + (dir / "split.g2o").string());
  EXPECT_EQ(d.exit_code, 1);
  EXPECT_NE(d.output.find("disconnected"), std::string::npos) << d.output;
}


// Benchmark files such as cubicle.g2o couple translation and rotation in their information
// matrices so that they are indefinite. tinyGrid3D with such couplings added to four edges: the
// chordal cost (SE-Sync: only the diagonal blocks, τ and κ) gives exactly the original graph's
// optimum; the geodesic cost gets the nearest positive-definite matrix and a warning naming the
// line; --strict and the library's default refuse, naming the line.
std::string withIndefiniteCouplings(std::vector<int>* lines) {
  std::ifstream in(sharedData("pose-graphs/tinyGrid3D.g2o"));
  std::string out, line;
  int n = 0, edges = 0;
  while (std::getline(in, line)) {
    ++n;
    std::istringstream ss(line);
    std::vector<std::string> t;
    for (std::string w; ss >> w;) t.push_back(w);
    if (!t.empty() && t[0] == "EDGE_SE3:QUAT" && edges++ % 3 == 0) {
      t[13] = "60";  // I14: t_x–r_x coupling; I11 = 100, I44 = 25, 60² > 100·25
      lines->push_back(n);
      line.clear();
      for (const auto& w : t) line += (line.empty() ? "" : " ") + w;
    }
    out += line + "\n";
  }
  return out;
}

TEST(G2oIndefiniteInformation, ChordalUsesDiagonalBlocksGeodesicProjects) {
  std::vector<int> lines;
  const std::string text = withIndefiniteCouplings(&lines);
  ASSERT_EQ(lines.size(), 4u);
  try {
    parseG2o(text, "cubicle-like.g2o");
    FAIL() << "strict reading accepted an indefinite matrix";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "cubicle-like.g2o:" + std::to_string(lines[0]) +
                                         ": information matrix is not positive definite");
  }
  G2oReadInfo info;
  PoseGraph blocks = parseG2o(text, "cubicle-like.g2o", &info, G2oInformation::DiagonalBlocks);
  EXPECT_EQ(info.adjusted_lines, lines);
  PoseGraph original = readG2o(sharedData("pose-graphs/tinyGrid3D.g2o"));
  for (std::size_t k = 0; k < original.edges.size(); ++k) {
    const ChordalWeights a = chordalWeights(original.edges[k], 3), b = chordalWeights(blocks.edges[k], 3);
    EXPECT_NEAR(a.tau, b.tau, 1e-12 * a.tau);
    EXPECT_NEAR(a.kappa, b.kappa, 1e-12 * a.kappa);
  }
  PoseGraphConfig chordal;
  chordal.cost = PoseGraphCost::Chordal;
  chordal.init = PoseGraphInit::Chordal;
  const PoseGraphReport ra = optimizePoseGraph(original, chordal), rb = optimizePoseGraph(blocks, chordal);
  EXPECT_NEAR(ra.final_chordal, rb.final_chordal, 1e-9 * ra.final_chordal);

  PoseGraph projected = parseG2o(text, "cubicle-like.g2o", &info, G2oInformation::NearestPositiveDefinite);
  EXPECT_EQ(info.adjusted_lines, lines);
  const Matrix6d right = informationLeftToRight(projected.edges[0].T_from_to, projected.edges[0].information);
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(right);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  EXPECT_GT(right(0, 3), 30.0);  // the coupling is kept as far as definiteness allows
  EXPECT_TRUE(optimizePoseGraph(projected, PoseGraphConfig{}).converged);

  const auto dir = test::scratchDir();
  const std::string file = (dir / "cubicle-like.g2o").string();
  std::ofstream(file) << text;
  const auto c = test::runCli("graph optimize '" + file + "' --cost chordal");
  EXPECT_EQ(c.exit_code, 0) << c.output;
  EXPECT_NE(c.output.find("note: " + file + ":" + std::to_string(lines[0]) +
                          ": information matrix is not positive definite; the chordal cost uses its "
                          "translation and rotation blocks only, as SE-Sync does (and 3 more edges)"),
            std::string::npos) << c.output;
  const auto g = test::runCli("graph optimize '" + file + "' --cost geodesic");
  EXPECT_EQ(g.exit_code, 0) << g.output;
  EXPECT_NE(g.output.find("warning: " + file + ":" + std::to_string(lines[0]) +
                          ": information matrix is not positive definite; projected to the nearest"),
            std::string::npos) << g.output;
  const auto s = test::runCli("graph optimize '" + file + "' --strict");
  EXPECT_NE(s.exit_code, 0);
  EXPECT_NE(s.output.find(file + ":" + std::to_string(lines[0]) + ": information matrix is not positive definite"),
            std::string::npos) << s.output;
}

}  // namespace
}  // namespace hazmap
