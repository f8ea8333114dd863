// Registration on real data: the scan pair with its published reference and the SemanticKITTI scans.
#include <gtest/gtest.h>

#include <cstdio>

#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/preprocess/crop.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/io/transform_file.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
using hazmap::test::rotErrDeg;
using hazmap::test::transErr;

class ScanPair : public ::testing::TestWithParam<std::tuple<bool, IcpMetric>> {};

TEST_P(ScanPair, LandsOnTheReference) {
  const auto [use_classes, metric] = GetParam();
  const auto dir = hazmap::test::sharedData("scan-pair");
  const ClassTable table = ClassTable::defaults();
  const LabeledCloud target_raw = readPcd(dir / "251370668.pcd", table);
  const LabeledCloud source_raw = readPcd(dir / "251371071.pcd", table);
  const Eigen::Isometry3d reference = readTransformFile(dir / "relative.txt");
  const Eigen::Isometry3d small_gicp = readTransformFile(dir / "small_gicp_T_target_source.txt");
  VoxelDownsampleConfig vd;
  vd.voxel_size = 0.25;
  const LabeledCloud target = voxelDownsample(target_raw, vd, table);
  const LabeledCloud source = voxelDownsample(source_raw, vd, table);
  RegistrationConfig cfg;
  cfg.use_classes = use_classes;
  cfg.metric = metric;
  cfg.max_iterations = 100;
  const auto r = registerClouds(source, target, Eigen::Isometry3d::Identity(), table, cfg);
  // Preprocessing and registration in one call (overlapped): the same answer, bit for bit.
  const auto overlapped = registerScans(source_raw, target_raw, Eigen::Isometry3d::Identity(), table, vd, cfg);
  EXPECT_TRUE(overlapped.transform.matrix() == r.transform.matrix());
  EXPECT_TRUE(overlapped.covariance == r.covariance);
  std::printf("scan pair %s/%s: %d iterations, vs relative.txt %.3f m %.3f deg, vs small_gicp %.3f m "
              "%.3f deg, fitness %.3f rmse %.3f, sd x %.4f yaw %.4f deg\n",
              use_classes ? "property" : "plain", toString(metric), r.iterations,
              transErr(r.transform, reference), rotErrDeg(r.transform, reference),
              transErr(r.transform, small_gicp), rotErrDeg(r.transform, small_gicp), r.fitness,
              r.inlier_rmse, std::sqrt(r.covariance(0, 0)), std::sqrt(r.covariance(5, 5)) * 180 / M_PI);
  EXPECT_TRUE(r.converged) << r.reason;
  EXPECT_LT(transErr(r.transform, reference), 0.05);
  EXPECT_LT(rotErrDeg(r.transform, reference), 0.5);
  EXPECT_LT(transErr(r.transform, small_gicp), 0.05);
  EXPECT_LT(rotErrDeg(r.transform, small_gicp), 0.5);
  EXPECT_GT(r.fitness, 0.8);
  EXPECT_TRUE(r.degenerate_directions.empty());
}

INSTANTIATE_TEST_SUITE_P(All, ScanPair,
                         ::testing::Combine(::testing::Bool(),
                                            ::testing::Values(IcpMetric::PointToPoint,
                                                              IcpMetric::PointToPlane)));
