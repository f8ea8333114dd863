// Pose-graph acceptance on the standard benchmark graphs (../shared/data/pose-graphs): with the
// chordal cost the final objective is within 0.1 % of SE-Sync's published global optimum F*, and
// the optimised sphere2500 is compared with its true poses by ATE after SE(3) Umeyama alignment.
// torus3D also shows the trap the chordal initialisation avoids (local minimum from the file).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <sstream>

#include "hazmap/graph/optimizer.hpp"
#include "hazmap/graph/g2o.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using test::sharedData;

PoseGraphReport optimiseChordal(PoseGraph& g) {
  PoseGraphConfig c;
  c.cost = PoseGraphCost::Chordal;
  c.init = PoseGraphInit::Chordal;
  c.loop_loss = LoopLoss::None;
  return optimizePoseGraph(g, c);
}

void expectNearOptimum(const char* name, double f_star) {
  PoseGraph g = readG2o(sharedData(std::string("pose-graphs/") + name + ".g2o"));
  const PoseGraphReport r = optimiseChordal(g);
  std::printf("%s: F = %.6g (F* = %.4g, %+.4f %%), %d iterations\n", name, r.final_chordal,
              f_star, 100.0 * (r.final_chordal - f_star) / f_star, r.iterations);
  EXPECT_LT(std::abs(r.final_chordal - f_star) / f_star, 1e-3) << name;
}

TEST(GraphDatasets, ManhattanReachesPublishedOptimum) { expectNearOptimum("manhattan", 6.432e3); }

TEST(GraphDatasets, CsailReachesPublishedOptimum) { expectNearOptimum("CSAIL", 3.170e1); }

TEST(GraphDatasets, Torus3DReachesPublishedOptimumFromChordalInit) {
  expectNearOptimum("torus3D", 2.423e4);
}

/// True poses of sphere2500: compose the noise-free odometry chain (GTSAM EDGE3 lines,
/// i j x y z roll pitch yaw, R = Rz(yaw) Ry(pitch) Rx(roll)).
std::vector<Eigen::Isometry3d> sphereTruth(int n) {
  std::ifstream in(sharedData("pose-graphs/sphere2500_groundtruth_edges.txt"));
  EXPECT_TRUE(in.good());
  std::vector<Eigen::Isometry3d> relative(n);
  std::vector<bool> have(n, false);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string tag;
    long i, j;
    double x, y, z, roll, pitch, yaw;
    if (!(ss >> tag >> i >> j >> x >> y >> z >> roll >> pitch >> yaw) || tag != "EDGE3") continue;
    if (j == i + 1 && j < n) {
      relative[j] = fromXyzRpy(x, y, z, roll, pitch, yaw);
      have[j] = true;
    }
  }
  std::vector<Eigen::Isometry3d> truth(n, Eigen::Isometry3d::Identity());
  for (int k = 1; k < n; ++k) {
    EXPECT_TRUE(have[k]) << "no ground-truth odometry edge into " << k;
    truth[k] = normalized(truth[k - 1] * relative[k]);
  }
  return truth;
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

TEST(GraphDatasets, Sphere2500ReachesOptimumAndTruePoses) {
  PoseGraph g = readG2o(sharedData("pose-graphs/sphere2500.g2o"));
  ASSERT_EQ(g.numNodes(), 2500);
  const auto truth = sphereTruth(g.numNodes());
  const double ate_file = ate(g.poses, truth);
  const PoseGraphReport r = optimiseChordal(g);
  const double ate_opt = ate(g.poses, truth);
  // Sanity of the ground-truth convention: the true relative poses agree with the noisy
  // measurements of the loop edges to within the noise (a few degrees).
  double worst_angle = 0.0;
  for (const auto& e : g.edges)
    worst_angle = std::max(worst_angle, rotationAngle(e.T_from_to.inverse() *
                                                       truth[e.from].inverse() * truth[e.to]));
  std::printf("sphere2500: F = %.6g (F* = 1.687e3, %+.4f %%), %d iterations; ATE file %.4f m, "
              "optimised %.4f m; worst edge rotation error vs truth %.2f deg\n",
              r.final_chordal, 100.0 * (r.final_chordal - 1.687e3) / 1.687e3, r.iterations,
              ate_file, ate_opt, worst_angle * 180.0 / M_PI);
  EXPECT_LT(std::abs(r.final_chordal - 1.687e3) / 1.687e3, 1e-3);
  EXPECT_LT(worst_angle, 10.0 * M_PI / 180.0);
  EXPECT_LT(ate_opt, 0.5 * ate_file);
  EXPECT_LT(ate_opt, 0.5);  // metres, on a sphere of radius ≈ 50 m
}

}  // namespace
}  // namespace hazmap
