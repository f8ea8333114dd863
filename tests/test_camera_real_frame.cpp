// The real camera + LiDAR frame in ../shared/data/cameras/pjlab-center-camera (README there):
// projected through hazmap's camera chain (plumb_bob lens, camera ← LiDAR extrinsic) the points
// fall on the car in the middle of the road and on the tall lamp post on the right to within
// a few pixels, found in the image itself (the car's bright body, the post's dark column
// against the sky). The same check with the extrinsic turned by 1° (37 px at f = 2110 px)
// fails, so it measures the chain, not the tolerance. Measured: car edges 945/1036 px against
// the image's 945/1028, the post 1520 px against 1524.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <stb/stb_image.h>

#include <algorithm>
#include <cmath>

#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/properties/camera_model.hpp"
#include "real_camera_frame.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using test::RealCameraCalibration;
using test::readRealCameraCalibration;

struct Frame {
  LabeledCloud cloud;
  CameraModel camera;
  Eigen::Isometry3d T_camera_lidar = Eigen::Isometry3d::Identity();
  int width = 0, height = 0;
  std::vector<float> grey;  ///< mean of R, G, B per pixel
  float at(int u, int v) const { return grey[static_cast<std::size_t>(v) * width + u]; }
};

Frame loadFrame() {
  const auto dir = test::sharedData("cameras/pjlab-center-camera");
  Frame f;
  f.cloud = readPcd(dir / "0.pcd");
  int comp = 0;
  stbi_uc* rgb = stbi_load((dir / "0.png").c_str(), &f.width, &f.height, &comp, 3);
  if (!rgb) throw std::runtime_error("cannot read 0.png");
  for (int i = 0; i < f.width * f.height; ++i) f.grey.push_back((rgb[3 * i] + rgb[3 * i + 1] + rgb[3 * i + 2]) / 3.0f);
  stbi_image_free(rgb);
  // The image's 1200 rows, not img_dist_h's 1080 (README).
  const RealCameraCalibration c = readRealCameraCalibration(f.width, f.height);
  f.camera = CameraModel(c.intrinsics, "center_camera");
  f.T_camera_lidar = c.T_camera_lidar;
  return f;
}

/// Pixels of the LiDAR points inside a box of the LiDAR frame.
std::vector<Eigen::Vector2d> projectBox(const Frame& f, const Eigen::Isometry3d& T, const Eigen::Vector3f& lo,
                                        const Eigen::Vector3f& hi) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& p : f.cloud.points)
    if ((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all())
      if (const auto px = f.camera.project(T * p.cast<double>(), 0.5)) out.push_back(*px);
  return out;
}

struct Check {
  double car_left, car_right, post_u;  // projected: the car's points' u range, the post's mean u
};

Check measure(const Frame& f, const Eigen::Isometry3d& T) {
  // The car ahead (back at x ≈ 40.4 m) and the lamp post on the right (x 28.9 m, y −7.4 m).
  const auto car = projectBox(f, T, {40.0f, -1.3f, -1.9f}, {42.5f, 0.6f, 0.2f});
  const auto post = projectBox(f, T, {28.5f, -7.7f, 0.5f}, {29.2f, -7.0f, 6.0f});
  EXPECT_GT(car.size(), 80u);
  EXPECT_GT(post.size(), 20u);
  Check c{1e9, -1e9, 0.0};
  for (const auto& p : car) c.car_left = std::min(c.car_left, p.x()), c.car_right = std::max(c.car_right, p.x());
  for (const auto& p : post) c.post_u += p.x() / static_cast<double>(post.size());
  return c;
}

TEST(RealCameraFrame, PointsFallOnTheCarAndTheLampPost) {
  const Frame f = loadFrame();
  ASSERT_EQ(f.width, 1920);
  ASSERT_EQ(f.height, 1200);
  ASSERT_EQ(f.cloud.size(), 78238u);
  // In the image: the car's body is the bright blob (grey > 170) on the road ahead; the lamp
  // post is the band of columns darker than the sky (by 10 grey levels over rows 150-400)
  // near the image's right; its centre is the post's axis.
  int left = f.width, right = -1;
  for (int v = 590; v < 690; ++v)
    for (int u = 900; u < 1100; ++u)
      if (f.at(u, v) > 170) left = std::min(left, u), right = std::max(right, u);
  std::vector<double> column;
  for (int u = 1480; u < 1600; ++u) {  // right of the traffic light's box (1400-1460)
    double sum = 0.0;
    for (int v = 150; v < 400; ++v) sum += f.at(u, v);
    column.push_back(sum / 250.0);
  }
  std::vector<double> sorted = column;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  double post = 0.0, band = 0.0;
  for (std::size_t k = 0; k < column.size(); ++k)
    if (column[k] < sorted[sorted.size() / 2] - 10.0) post += 1480.0 + static_cast<double>(k), band += 1.0;
  ASSERT_GE(band, 5.0);  // a post about ten pixels wide, not one dark pixel
  post /= band;
  ASSERT_GT(right - left, 60);  // a car's width at 40 m, not a stray pixel

  const Check c = measure(f, f.T_camera_lidar);
  EXPECT_NEAR(c.car_left, left, 8.0);
  EXPECT_NEAR(c.car_right, right, 12.0);  // the rightmost returns are the car's side, a little wider
  EXPECT_NEAR(c.post_u, post, 6.0);

  // The extrinsic turned by 1° about the camera's y axis: everything ~37 px sideways, caught.
  Eigen::Isometry3d off = f.T_camera_lidar;
  off.linear() = Eigen::AngleAxisd(M_PI / 180.0, Eigen::Vector3d::UnitY()) * off.linear();
  const Check bad = measure(f, off);
  EXPECT_GT(std::abs(bad.post_u - post), 20.0);
  EXPECT_GT(std::abs(bad.car_left - left), 20.0);
}

}  // namespace
}  // namespace hazmap
