// The properties stage: camera model, calibration files, images, projection with the depth
// test, rules and the labeler (issue 16). End-to-end precision/recall: test_properties_sim.cpp.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/labeler.hpp"
#include "hazmap/properties/view_fusion.hpp"
#include "hazmap/properties/projection.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/properties/rules.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

CameraIntrinsics pinhole() {
  CameraIntrinsics k;
  k.width = 640;
  k.height = 480;
  k.fx = 500;
  k.fy = 400;
  k.cx = 320;
  k.cy = 240;
  return k;
}

TEST(CameraModel, PinholeProjectsToHandComputedPixels) {
  const CameraModel cam(pinhole());
  // (1, 0.5, 5): x/z = 0.2, y/z = 0.1 → u = 500·0.2 + 320 = 420, v = 400·0.1 + 240 = 280.
  const auto px = cam.project({1.0, 0.5, 5.0});
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->x(), 420.0, 1e-12);
  EXPECT_NEAR(px->y(), 280.0, 1e-12);
  EXPECT_FALSE(cam.project({1.0, 0.5, -5.0}));   // behind
  EXPECT_FALSE(cam.project({10.0, 0.0, 5.0}));   // u = 1320: outside
  EXPECT_TRUE(cam.project({-3.2, 0.0, 5.0}));    // u = 500·(−0.64) + 320 = 0
}

TEST(CameraModel, ImageBorderIsHalfAPixelOutsideTheCentres) {
  const CameraModel cam(pinhole());
  EXPECT_TRUE(cam.inImage({-0.49, -0.49}));
  EXPECT_FALSE(cam.inImage({-0.51, 10}));
  EXPECT_TRUE(cam.inImage({639.49, 479.49}));
  EXPECT_FALSE(cam.inImage({639.5, 10}));
}

TEST(CameraModel, PlumbBobMatchesHandComputedOpenCvValues) {
  CameraIntrinsics k = pinhole();
  k.distortion = DistortionModel::RadialTangential;
  k.coeffs = {-0.2, 0.05, 0.001, -0.002, 0.0};
  const CameraModel cam(k);
  // x = 0.3, y = -0.2: r² = 0.13, radial = 1 − 0.2·0.13 + 0.05·0.0169 = 0.974845
  // x' = 0.3·0.974845 + 2·0.001·0.3·(−0.2) − 0.002·(0.13 + 2·0.09) = 0.2917135
  // y' = −0.2·0.974845 + 0.001·(0.13 + 2·0.04) + 2·(−0.002)·0.3·(−0.2) = −0.194519
  const Eigen::Vector2d d = cam.distort({0.3, -0.2});
  EXPECT_NEAR(d.x(), 0.2917135, 1e-12);
  EXPECT_NEAR(d.y(), -0.194519, 1e-12);
  const auto px = cam.project({0.3 * 4, -0.2 * 4, 4.0});
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->x(), 500 * 0.2917135 + 320, 1e-9);  // 465.85675
  EXPECT_NEAR(px->y(), 400 * -0.194519 + 240, 1e-9);  // 162.1924
  const Eigen::Vector2d u = cam.undistort(d);
  EXPECT_NEAR(u.x(), 0.3, 1e-12);
  EXPECT_NEAR(u.y(), -0.2, 1e-12);
}

TEST(CameraModel, EquidistantMatchesHandComputedOpenCvFisheyeValues) {
  CameraIntrinsics k = pinhole();
  k.distortion = DistortionModel::Equidistant;
  k.coeffs = {0.1, 0.01, 0.002, 0.0005, 0.0};
  const CameraModel cam(k);
  // a = 0.5, b = −0.25: r = 0.559017, θ = atan r = 0.5104195,
  // θd = θ(1 + 0.1θ² + 0.01θ⁴ + 0.002θ⁶ + 0.0005θ⁸) = 0.5233594, scale θd/r = 0.9361928.
  const Eigen::Vector2d d = cam.distort({0.5, -0.25});
  EXPECT_NEAR(d.x(), 0.4680963844610766, 1e-12);
  EXPECT_NEAR(d.y(), -0.2340481922305383, 1e-12);
  const auto px = cam.project({0.5, -0.25, 1.0});
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->x(), 554.0481922305382, 1e-9);
  EXPECT_NEAR(px->y(), 146.3807231077847, 1e-9);
}

TEST(CameraModel, UnprojectInvertsProjectOverTheWholeImage) {
  for (DistortionModel model : {DistortionModel::None, DistortionModel::RadialTangential, DistortionModel::Equidistant}) {
    CameraIntrinsics k = pinhole();
    k.distortion = model;
    k.coeffs = model == DistortionModel::Equidistant ? std::array<double, 5>{-0.05, 0.01, -0.002, 0.0003, 0}
                                                     : std::array<double, 5>{-0.28, 0.07, 0.0008, -0.0004, -0.006};
    const CameraModel cam(k);
    double worst = 0;
    for (double u = -0.4; u < 640; u += 31.7)
      for (double v = -0.4; v < 480; v += 23.3) {
        const Eigen::Vector3d ray = cam.unproject({u, v});
        EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
        const auto back = cam.project(ray * 7.0);
        ASSERT_TRUE(back) << toString(model) << " at " << u << "," << v;
        worst = std::max(worst, (*back - Eigen::Vector2d(u, v)).norm());
      }
    EXPECT_LT(worst, 1e-7) << toString(model);
  }
}

TEST(CameraModel, RejectsPointsWhereTheDistortionPolynomialFoldsBack) {
  CameraIntrinsics k = pinhole();
  k.distortion = DistortionModel::RadialTangential;
  k.coeffs = {-0.2, 0.0, 0.0, 0.0, 0.0};  // x' = x(1 − 0.2r²) turns back at r ≈ 1.29
  const CameraModel cam(k);
  // At r = 2.2, x' = 2.2·(1 − 0.968) = 0.07: a naive projection lands near the image centre.
  EXPECT_FALSE(cam.project({2.2, 0.0, 1.0}));
  EXPECT_FALSE(cam.project({1.35, 0.0, 1.0}));  // just past the fold
  EXPECT_TRUE(cam.project({0.5, 0.0, 1.0}));
}

TEST(CameraModel, ValidationNamesTheProblem) {
  CameraIntrinsics k = pinhole();
  k.fx = -500;
  EXPECT_THROW(CameraModel(k, "cam"), Error);
  k = pinhole();
  k.cx = 900;
  EXPECT_THROW(CameraModel(k, "cam"), Error);
  k = pinhole();
  k.width = 0;
  EXPECT_THROW(CameraModel(k, "cam"), Error);
}

const char* kCameraYaml = R"(image_width: 640
image_height: 480
camera_name: flir
camera_matrix: {rows: 3, cols: 3, data: [500, 0, 320, 0, 400, 240, 0, 0, 1]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [-0.2, 0.05, 0.001, -0.002, 0]}
rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}
projection_matrix: {rows: 3, cols: 4, data: [500, 0, 320, 0, 0, 400, 240, 0, 0, 0, 1, 0]}
T_camera_lidar: {rows: 4, cols: 4, data: [0, -1, 0, 0.1, 0, 0, -1, 0.2, 1, 0, 0, 0.3, 0, 0, 0, 1]}
time_offset: -0.02
channel: {name: temperature}
)";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

std::string errorOf(const std::string& yaml) {
  try {
    parseCameraYaml(yaml, "cam.yaml");
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CameraYaml, ReadsRosCameraInfoFieldsAndExtrinsics) {
  const CameraCalibration cam = parseCameraYaml(kCameraYaml, "cam.yaml", "/data");
  EXPECT_EQ(cam.name, "flir");
  EXPECT_EQ(cam.model.width(), 640);
  EXPECT_EQ(cam.model.intrinsics().fy, 400);
  EXPECT_EQ(cam.model.intrinsics().distortion, DistortionModel::RadialTangential);
  EXPECT_EQ(cam.model.intrinsics().coeffs[3], -0.002);
  EXPECT_EQ(cam.T_camera_lidar.translation(), Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_TRUE((cam.T_camera_lidar * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d(0.1, 0.2, 1.3)));
  EXPECT_EQ(cam.time_offset, -0.02);
  EXPECT_EQ(cam.channel.name, "temperature");
  EXPECT_DOUBLE_EQ(cam.channel.scale, 0.01);  // centikelvin
  EXPECT_DOUBLE_EQ(cam.channel.offset, -273.15);
  // Written and read back: the same numbers (the rotation to its last bit only without FMA: a
  // -march=native build reads back -2.2e-17 for +2.2e-17).
  const CameraCalibration back = parseCameraYaml(cameraYaml(cam, ""), "back.yaml");
  EXPECT_LT((back.T_camera_lidar.matrix() - cam.T_camera_lidar.matrix()).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(back.model.intrinsics().coeffs, cam.model.intrinsics().coeffs);
  EXPECT_EQ(back.time_offset, cam.time_offset);
}

TEST(CameraYaml, ErrorsNameTheFileAndTheKey) {
  EXPECT_NE(errorOf(replaced(kCameraYaml, "image_height: 480\n", "")).find("cam.yaml: missing key 'image_height'"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "data: [500, 0, 320", "data: [-500, 0, 320")).find("camera_matrix"),
            std::string::npos);
  // A shear is not a rotation.
  EXPECT_NE(errorOf(replaced(kCameraYaml, "data: [0, -1, 0, 0.1", "data: [0.2, -1, 0, 0.1")).find("T_camera_lidar"),
            std::string::npos);
  // A reflection (det −1) is not a rotation either.
  EXPECT_NE(errorOf(replaced(kCameraYaml, "data: [0, -1, 0, 0.1", "data: [0, 1, 0, 0.1")).find("T_camera_lidar"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "T_camera_lidar: {rows: 4, cols: 4, data: [0, -1, 0, 0.1, 0, 0, -1, 0.2, 1, 0, 0, 0.3, 0, 0, 0, 1]}\n", ""))
                .find("missing key 'T_camera_lidar'"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "plumb_bob", "rational_polynomial")).find("distortion_model"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "-0.002, 0]", "-0.002, 0, 7]")).find("distortion_coefficients"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "time_offset", "time_ofset")).find("unknown key 'time_ofset'"),
            std::string::npos);
  EXPECT_NE(errorOf(replaced(kCameraYaml, "channel: {name: temperature}\n", "")).find("missing key 'channel'"),
            std::string::npos);
  EXPECT_NE(errorOf("[1, 2").find("cam.yaml"), std::string::npos);
}

TEST(PropertyImages, Png16RoundTripIsExact) {
  Gray16 img;
  img.width = 37;
  img.height = 11;
  for (int i = 0; i < img.width * img.height; ++i) img.pixels.push_back(static_cast<std::uint16_t>(i * 977 % 65536));
  const auto dir = test::scratchDir();
  writePng16(dir / "a.png", img);
  const Gray16 back = readGray16(dir / "a.png");
  EXPECT_EQ(back.width, 37);
  EXPECT_EQ(back.height, 11);
  EXPECT_EQ(back.pixels, img.pixels);
}

/// A minimal uncompressed 16-bit grayscale TIFF, written byte by byte.
std::string tiff(bool big_endian, int w, int h, const std::vector<std::uint16_t>& px) {
  std::string b;
  const auto put = [&](std::uint32_t v, int n) {
    for (int i = 0; i < n; ++i) b.push_back(static_cast<char>(big_endian ? v >> (8 * (n - 1 - i)) : v >> (8 * i)));
  };
  b += big_endian ? "MM" : "II";
  put(42, 2);
  put(8, 4);  // IFD right after the header
  const std::uint32_t data_offset = 8 + 2 + 7 * 12 + 4;
  put(7, 2);
  const auto entry = [&](int tag, int type, std::uint32_t value) {
    put(tag, 2), put(type, 2), put(1, 4);
    if (type == 3) put(value, 2), put(0, 2);
    else put(value, 4);
  };
  entry(256, 3, w);
  entry(257, 3, h);
  entry(258, 3, 16);
  entry(259, 3, 1);
  entry(262, 3, 1);
  entry(273, 4, data_offset);
  entry(279, 4, 2 * w * h);
  put(0, 4);
  for (std::uint16_t p : px) put(p, 2);
  return b;
}

TEST(PropertyImages, ReadsUncompressedTiffInBothByteOrders) {
  const auto dir = test::scratchDir();
  const std::vector<std::uint16_t> px = {1, 2, 300, 40000, 65535, 7};
  for (bool be : {false, true}) {
    writeTextAtomically(dir / "a.tif", tiff(be, 3, 2, px));
    const Gray16 img = readGray16(dir / "a.tif");
    EXPECT_EQ(img.width, 3);
    EXPECT_EQ(img.height, 2);
    EXPECT_EQ(img.pixels, px);
  }
  std::string truncated = tiff(false, 3, 2, px);
  truncated.resize(truncated.size() - 3);
  writeTextAtomically(dir / "b.tif", truncated);
  EXPECT_THROW(readGray16(dir / "b.tif"), Error);
  writeTextAtomically(dir / "c.png", "not an image");
  EXPECT_THROW(readGray16(dir / "c.png"), Error);
}

CameraCalibration smallCamera(int w, int h) {
  CameraIntrinsics k;
  k.width = w;
  k.height = h;
  k.fx = k.fy = 10;
  k.cx = (w - 1) / 2.0;
  k.cy = (h - 1) / 2.0;
  CameraCalibration cam;
  cam.model = CameraModel(k);
  cam.channel = defaultChannel("temperature");
  return cam;
}

TEST(PropertyImages, ConvertsRosImageEncodings) {
  const CameraCalibration cam = smallCamera(2, 1);
  ImageMsg msg;
  msg.width = 2;
  msg.height = 1;
  msg.encoding = "mono16";
  msg.step = 4;
  msg.data = {0x8B, 0x72, 0xBA, 0x88};  // little endian 29323 (20.08 °C), 35002 (76.87 °C)
  PropertyImage img = imageFromMessage(msg, cam, "bag");
  EXPECT_NEAR(img.values[0], 20.08, 1e-4);
  EXPECT_NEAR(img.values[1], 76.87, 1e-4);
  msg.is_bigendian = true;
  msg.data = {0x72, 0x8B, 0x88, 0xBA};
  img = imageFromMessage(msg, cam, "bag");
  EXPECT_NEAR(img.values[1], 76.87, 1e-4);

  msg.is_bigendian = false;
  msg.encoding = "32FC1";
  msg.step = 8;
  const float celsius[2] = {21.5f, 99.0f};
  msg.data.resize(8);
  std::memcpy(msg.data.data(), celsius, 8);
  img = imageFromMessage(msg, cam, "bag");
  EXPECT_FLOAT_EQ(img.values[1], 99.0f);

  CameraCalibration nir = cam;
  nir.channel = defaultChannel("nir_reflectance");
  nir.channel.scale = 1.0 / 255.0;
  msg.encoding = "mono8";
  msg.step = 4;  // padded rows
  msg.data = {51, 255, 0, 0};
  img = imageFromMessage(msg, nir, "bag");
  EXPECT_NEAR(img.values[0], 0.2, 1e-6);
  EXPECT_NEAR(img.values[1], 1.0, 1e-6);

  // Colour stands in through its luminance (Rec. 601), as an 8-bit count.
  msg.encoding = "bgr8";
  msg.step = 6;
  msg.data = {0, 0, 255, 255, 255, 255};  // pure red, white
  img = imageFromMessage(msg, nir, "bag");
  EXPECT_NEAR(img.values[0], 0.299, 1e-6);
  EXPECT_NEAR(img.values[1], 1.0, 1e-6);
  msg.encoding = "16SC1";
  msg.step = 4;
  msg.data = {0xFF, 0xFF, 0x02, 0x00};  // -1, 2
  img = imageFromMessage(msg, smallCamera(2, 1), "bag");
  EXPECT_NEAR(img.values[0], -0.01 - 273.15, 1e-4);
  EXPECT_NEAR(img.values[1], 0.02 - 273.15, 1e-4);
  // An encoding hazmap cannot read: one line naming where (bag: topic message) and the encoding.
  msg.encoding = "yuv422";
  try {
    (void)imageFromMessage(msg, cam, "bag.mcap: /thermal/image_raw message 0");
    ADD_FAILURE() << "yuv422 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/thermal/image_raw message 0: image encoding 'yuv422' is not supported"),
              std::string::npos) << e.what();
  }
  msg.encoding = "mono16";
  msg.step = 4;
  msg.data.resize(3);
  EXPECT_THROW(imageFromMessage(msg, cam, "bag"), Error);
  msg.width = 3;
  EXPECT_THROW(imageFromMessage(msg, cam, "bag"), Error);
}

PropertyImage gradientImage(int w, int h) {
  PropertyImage img;
  img.width = w;
  img.height = h;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) img.values.push_back(static_cast<float>(x + 10 * y));
  return img;
}

TEST(Projection, BilinearValueAtTheProjectedPixel) {
  const CameraModel cam(pinhole());
  const PropertyImage img = gradientImage(640, 480);
  // (0.2, 0.05, 1) → u = 420, v = 260; (0.2005, 0.05125, 1) → u = 420.25, v = 260.5.
  const std::vector<Eigen::Vector3f> pts = {{0.2f, 0.05f, 1.0f}, {0.2005f, 0.05125f, 1.0f}, {0, 0, -1}};
  std::vector<float> values(3, NAN);
  const auto stats = projectIntoImage(pts, Eigen::Isometry3d::Identity(), cam, img, {}, values);
  EXPECT_NEAR(values[0], 420 + 10 * 260, 1e-3);
  EXPECT_NEAR(values[1], 420.25 + 10 * 260.5, 1e-2);
  EXPECT_TRUE(std::isnan(values[2]));  // behind the camera: not observed, not 0
  EXPECT_EQ(stats.in_view, 2u);
  EXPECT_EQ(stats.observed, 2u);
}

TEST(Projection, PointsBehindANearerSurfaceGetNothing) {
  CameraIntrinsics k = pinhole();
  const CameraModel cam(k);
  PropertyImage img;
  img.width = 640;
  img.height = 480;
  img.values.assign(640 * 480, 80.0f);
  std::vector<Eigen::Vector3f> pts;
  // A wall at 5 m covering x in [-1, 1] (pixels 220..420), sampled every 10 cm.
  for (float x = -1.0f; x <= 1.0f; x += 0.1f)
    for (float y = -0.5f; y <= 0.5f; y += 0.1f) pts.emplace_back(x, y, 5.0f);
  const std::size_t wall = pts.size();
  pts.emplace_back(0.05f, 0.05f, 10.0f);  // behind the wall
  pts.emplace_back(4.0f, 0.0f, 10.0f);    // beside it (u = 520): visible
  pts.emplace_back(0.06f, 0.02f, 5.1f);   // on the wall's surface within the tolerance
  std::vector<float> values(pts.size(), NAN);
  const auto stats = projectIntoImage(pts, Eigen::Isometry3d::Identity(), cam, img, {}, values);
  EXPECT_TRUE(std::isnan(values[wall]));
  EXPECT_EQ(values[wall + 1], 80.0f);
  EXPECT_EQ(values[wall + 2], 80.0f);
  EXPECT_EQ(stats.occluded, 1u);
  // Without the splat, the hidden point falls between the wall's samples and "sees through".
  ProjectionConfig no_splat;
  no_splat.depth_cell_px = 1;
  no_splat.splat_cells = 0;
  std::fill(values.begin(), values.end(), NAN);
  projectIntoImage(pts, Eigen::Isometry3d::Identity(), cam, img, no_splat, values);
  EXPECT_EQ(values[wall], 80.0f);
}

TEST(Projection, ExtrinsicsMoveThePoints) {
  const CameraModel cam(pinhole());
  const PropertyImage img = gradientImage(640, 480);
  // LiDAR frame (x forward, y left, z up) into the optical frame, camera 1 m left of the LiDAR.
  Eigen::Isometry3d T_lidar_camera = Eigen::Isometry3d::Identity();
  T_lidar_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  T_lidar_camera.translation() = Eigen::Vector3d(0, 1, 0);
  const std::vector<Eigen::Vector3f> pts = {{5.0f, 1.0f, 0.0f}};  // straight ahead of the camera
  std::vector<float> values(1, NAN);
  projectIntoImage(pts, T_lidar_camera.inverse(), cam, img, {}, values);
  EXPECT_NEAR(values[0], 320 + 10 * 240, 1e-3);
}

TEST(Rules, ParsesEvaluatesAndFirstMatchWins) {
  const ClassTable table = ClassTable::defaults();
  const PropertyRules rules = PropertyRules::parse(
      "heat: temperature >= 60\n"
      "water: nir_reflectance <= 0.2 and normal_z > 0.9 or (nir_reflectance < 0.05)\n"
      "radiation: not dose_rate < 10\n",
      "rules.yaml", table);
  ASSERT_EQ(rules.rules().size(), 3u);
  const auto& v = rules.variables();
  ASSERT_EQ(v, (std::vector<std::string>{"temperature", "nir_reflectance", "normal_z", "dose_rate"}));
  const auto cls = [&](float t, float nir, float nz, float dose) {
    const float values[4] = {t, nir, nz, dose};
    return rules.classify(values);
  };
  EXPECT_EQ(cls(60.0f, 0.1f, 1.0f, 50.0f), 1);  // heat first
  EXPECT_EQ(cls(59.9f, 0.1f, 1.0f, 50.0f), 2);  // water
  EXPECT_EQ(cls(NAN, 0.1f, 0.5f, 50.0f), 3);    // not flat enough for water → radiation
  EXPECT_EQ(cls(NAN, 0.01f, 0.5f, NAN), 2);     // the `or` branch
  EXPECT_EQ(cls(20.0f, 0.6f, 1.0f, 1.0f), 0);
  // Not observed is never a hazard: NaN fails every comparison, even under `not`.
  EXPECT_EQ(cls(NAN, NAN, NAN, NAN), 3);  // documents that `not x < 10` holds for NaN
  EXPECT_TRUE(rules.usesNormalZ());
}

TEST(Rules, ListFormAndErrors) {
  const ClassTable table = ClassTable::defaults();
  const PropertyRules list = PropertyRules::parse("rules:\n  - heat: temperature > 50\n  - water: nir_reflectance == 0\n",
                                                  "r.yaml", table);
  EXPECT_EQ(list.rules().size(), 2u);
  const auto message = [&](const std::string& yaml) {
    try {
      PropertyRules::parse(yaml, "r.yaml", table);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message("heat: temperature >> 60").find("column"), std::string::npos);
  EXPECT_NE(message("heat: temperature >= ").find("expected a number"), std::string::npos);
  EXPECT_NE(message("heat: (temperature >= 60").find("missing ')'"), std::string::npos);
  EXPECT_NE(message("lava: temperature >= 600").find("'lava' is not in the class table"), std::string::npos);
  EXPECT_NE(message("heat: temperature >= 60 and").find("expected a channel name"), std::string::npos);
  EXPECT_NE(message("[]").find("r.yaml"), std::string::npos);
  const PropertyRules ok = PropertyRules::parse("heat: temp >= 60", "r.yaml", table);
  EXPECT_THROW(ok.checkChannels({"temperature"}, "r.yaml"), Error);
}

TEST(Rules, DefaultsFollowTheCamerasGiven) {
  const ClassTable table = ClassTable::defaults();
  EXPECT_EQ(PropertyRules::defaults({"temperature"}, table).rules().size(), 1u);
  EXPECT_EQ(PropertyRules::defaults({"temperature", "nir_reflectance", "dose_rate"}, table).rules().size(), 3u);
  EXPECT_TRUE(PropertyRules::defaults({"colour"}, table).rules().empty());
}

TEST(Labeler, NearestImageInTimeAndMotionCompensation) {
  CameraCalibration cam = smallCamera(41, 41);
  // Camera looks along the LiDAR's x axis.
  cam.T_camera_lidar.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  auto images = std::make_shared<MemoryImages>();
  for (int k = 0; k < 3; ++k) {
    PropertyImage img;
    img.width = img.height = 41;
    img.stamp = 10.0 * k;
    img.values.assign(41 * 41, 20.0f + k);
    // A hot column at pixel 20 (straight ahead) in image 1 only.
    if (k == 1)
      for (int y = 0; y < 41; ++y) img.values[y * 41 + 20] = 90.0f;
    images->add(img);
  }
  PropertyLabeler labeler({{cam, images}}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()));
  LabeledCloud scan;
  scan.push_back({4.0f, 0.0f, 0.0f});
  ScanLabels l = labeler.label(scan, 10.05, {});
  EXPECT_EQ(l.channels[0][0], 90.0f);
  EXPECT_EQ(l.classes[0], 1);
  l = labeler.label(scan, 5.0, {});  // 5 s from both neighbours: no image within 0.1 s
  EXPECT_TRUE(std::isnan(l.channels[0][0]));
  EXPECT_EQ(l.images_missing, 1u);
  EXPECT_EQ(l.classes[0], 0);
  // The robot moves 1 m/s along y; the image (t = 10) was taken 0.05 s before the scan (t = 10.05):
  // with compensation the point at y = 0.05 in the scan sits straight ahead of the image's camera.
  Trajectory poses;
  for (int k = 0; k <= 20; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation().y() = k;
    poses.push_back(k, T);
  }
  LabeledCloud moved;
  moved.push_back({4.0f, -0.05f, 0.0f});
  const auto pose_at = [&](double t) { return interpolatePose(poses, t); };
  l = labeler.label(moved, 10.05, pose_at);
  EXPECT_EQ(l.channels[0][0], 90.0f);
  LabelerConfig still;
  still.motion_compensation = false;
  PropertyLabeler no_comp({{cam, images}}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), still);
  l = no_comp.label(moved, 10.05, pose_at);
  EXPECT_LT(l.channels[0][0], 90.0f);  // 0.125 px off: interpolated with the cold neighbour
}

/// A NIR camera looking along the LiDAR's x axis whose one image is dark everywhere
/// (nir_reflectance 0.05): with the default rules a point it sees is water exactly where its
/// normal_z passes, so the normal decides.
PropertyLabeler darkFloorLabeler() {
  CameraCalibration cam = smallCamera(41, 41);
  cam.channel = defaultChannel("nir_reflectance");
  cam.T_camera_lidar.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // looking along x
  auto images = std::make_shared<MemoryImages>();
  PropertyImage img;
  img.width = img.height = 41;
  img.values.assign(41 * 41, 0.05f);
  images->add(img);
  return PropertyLabeler({{cam, images}}, PropertyRules::defaults({"nir_reflectance"}, ClassTable::defaults()));
}

// normal_z where the scan lines lie apart: a floor seen by two dense lines 0.6 m apart (a far
// floor's rings; each point's 20 nearest neighbours lie on its own line and fit no plane) gets its
// normal from both lines, and the water rule labels it; a wall seen the same way does not pass.
TEST(Labeler, FloorBetweenScanLinesGetsANormal) {
  const PropertyLabeler labeler = darkFloorLabeler();
  const auto scanOf = [](bool floor) {
    LabeledCloud scan;
    for (const float line : {0.0f, 0.6f})
      for (int k = -100; k <= 100; ++k) {
        const float y = 0.01f * static_cast<float>(k);
        scan.push_back(floor ? Eigen::Vector3f(3.0f + line, y, -0.5f) : Eigen::Vector3f(3.0f, y, -0.3f + line));
      }
    return scan;
  };
  const ScanLabels on_floor = labeler.label(scanOf(true), 0.0);
  const ScanLabels on_wall = labeler.label(scanOf(false), 0.0);
  const auto count = [](const ScanLabels& l, ClassId c) { return std::count(l.classes.begin(), l.classes.end(), c); };
  // The camera sees the nearer floor line (the farther one lies behind it within a pixel):
  // water (nir_reflectance <= 0.2 and normal_z > 0.9) on it all.
  EXPECT_EQ(count(on_floor, 2), 201);
  const auto seen = [](const ScanLabels& l) {
    return std::count_if(l.channels[0].begin(), l.channels[0].end(), [](float v) { return v == 0.05f; });
  };
  EXPECT_GE(seen(on_wall), 201);  // dark and seen, but upright: no water
  EXPECT_EQ(count(on_wall, 2), 0);
}

// normal_z on a far floor: a ring 9.5 m out lies metres from the next one, so neither its own
// line nor the thinned scan gives it a plane; lying on the floor plane fitted to the near floor,
// it takes that plane's normal (water on it, dark); the same line 0.4 m above the floor (a crate's
// top edge, a step) stays without a normal (no water).
TEST(Labeler, FarFloorRingTakesTheFloorPlanesNormal) {
  const PropertyLabeler labeler = darkFloorLabeler();
  constexpr float kFloor = -0.5f;
  const auto scanWithFarLineAt = [&](float z) {
    LabeledCloud scan;
    for (int i = 0; i <= 40; ++i)  // the near floor, to the side of the camera's view of the far line
      for (int j = 0; j <= 40; ++j) scan.push_back({1.0f + 0.05f * i, 4.0f + 0.05f * j, kFloor});
    for (int k = -50; k <= 50; ++k) scan.push_back({9.5f, 0.01f * static_cast<float>(k), z});
    return scan;
  };
  const auto farWater = [&](float z) {
    const LabeledCloud scan = scanWithFarLineAt(z);
    const ScanLabels l = labeler.label(scan, 0.0);
    long seen = 0, water = 0;
    for (std::size_t i = 41 * 41; i < scan.size(); ++i) {
      seen += l.channels[0][i] == 0.05f;
      water += l.classes[i] == 2 && l.channels[0][i] == 0.05f;
    }
    EXPECT_GE(seen, 80) << z;  // the camera sees (most of) the far line either way
    return water == seen ? 1.0 : static_cast<double>(water) / static_cast<double>(seen);
  };
  EXPECT_EQ(farWater(kFloor), 1.0);  // every seen point of it
  EXPECT_EQ(farWater(kFloor + 0.4f), 0.0);
}

TEST(Labeler, EdgeGuardRefusesClassesACalibrationErrorCouldFlip) {
  CameraCalibration cam = smallCamera(41, 41);
  cam.T_camera_lidar.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  auto images = std::make_shared<MemoryImages>();
  PropertyImage img;
  img.width = img.height = 41;
  for (int y = 0; y < 41; ++y)
    for (int x = 0; x < 41; ++x) img.values.push_back(x < 20 ? 90.0f : 20.0f);  // hot left half
  images->add(img);
  LabeledCloud scan;
  scan.push_back({4.0f, 1.2f, 0.0f});  // u = 10·(−1.2/4) + 20 = 17: hot, 3 px from the edge
  scan.push_back({4.0f, 3.2f, 0.0f});  // u = 12: hot, 8 px from the edge
  const auto rules = PropertyRules::defaults({"temperature"}, ClassTable::defaults());
  LabelerConfig config;
  EXPECT_EQ(PropertyLabeler({{cam, images}}, rules, config).label(scan, 0.0).classes, (std::vector<ClassId>{1, 1}));
  config.projection.edge_guard_px = 4;
  const ScanLabels l = PropertyLabeler({{cam, images}}, rules, config).label(scan, 0.0);
  EXPECT_EQ(l.classes, (std::vector<ClassId>{0, 1}));
  EXPECT_EQ(l.channels[0][0], 90.0f);  // the value stays: only the class is withheld
}

TEST(ViewFusion, EachSurfaceVoxelIsSampledInItsMostFrontalViewNearby) {
  // A wall along x at y = 2 seen by a forward camera from x = 0 (scan 0) and x = 2 (scan 1).
  // Image 0 reads 90 °C everywhere (as a grazing view off by a calibration error would), image
  // 1 reads 20 °C: the wall at x = 6 is seen more frontally from x = 2 (footprint 4.5 m / cos
  // 64° = 10 m/rad against 6.3 m / cos 72° = 20 m/rad), so both scans take image 1's 20 °C.
  CameraCalibration cam = smallCamera(41, 41);
  cam.T_camera_lidar.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  auto images = std::make_shared<MemoryImages>();
  for (int k = 0; k < 2; ++k) {
    PropertyImage img;
    img.width = img.height = 41;
    img.stamp = 10.0 * k;
    img.values.assign(41 * 41, k == 0 ? 90.0f : 20.0f);
    images->add(img);
  }
  LabelerConfig config;
  config.footprints = true;
  config.projection.depth_cell_px = 1;  // no occluder here, and this 41-px camera's cells would be wide
  config.projection.splat_cells = 0;
  const PropertyLabeler labeler({{cam, images}}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), config);
  Trajectory poses;
  for (int k = 0; k < 2; ++k) poses.push_back(10.0 * k, Eigen::Isometry3d(Eigen::Translation3d(2.0 * k, 0, 0)));
  std::vector<LabeledCloud> scans(2);
  for (int k = 0; k < 2; ++k)
    for (int ix = 0; ix <= 150; ++ix)
      for (int iz = -10; iz <= 10; ++iz)  // off the 0.1 m voxel boundaries
        scans[k].push_back({0.525f + 0.05f * ix - 2.0f * k, 2.03f, 0.025f + 0.05f * iz});
  const auto index_of = [](int /*scan: same order in both*/, float world_x) {  // the point at (world_x, 2, 0)
    return static_cast<std::size_t>(std::lround((world_x - 0.525f) / 0.05f)) * 21 + 10;
  };
  ViewFusionConfig fusion_config;
  ViewFusion fusion(labeler, fusion_config);
  std::vector<ScanLabels> labels(2);
  for (int k = 0; k < 2; ++k) {
    labels[k] = labeler.observe(scans[k], 10.0 * k);
    fusion.add(k, scans[k], poses.poses[k], 2.0 * k, labels[k]);
  }
  EXPECT_EQ(labels[0].channels[0][index_of(0, 6.025f)], 90.0f);
  EXPECT_TRUE(std::isnan(labels[1].channels[0][index_of(1, 2.525f)]));  // beside scan 1's camera: out of view
  for (int k = 0; k < 2; ++k) {
    fusion.fuse(k, scans[k], fusion.bestFrames(k, scans[k]), labels[k]);
    labeler.classify(scans[k], poses.poses[k], labels[k]);
  }
  EXPECT_FLOAT_EQ(labels[0].channels[0][index_of(0, 6.025f)], 20.0f);
  EXPECT_EQ(labels[0].classes[index_of(0, 6.025f)], 0);
  EXPECT_FLOAT_EQ(labels[1].channels[0][index_of(1, 6.025f)], 20.0f);
  // Scan 1 did not see x = 2.5, scan 0 did: the value comes from scan 0's image.
  EXPECT_FLOAT_EQ(labels[1].channels[0][index_of(1, 2.525f)], 90.0f);
  EXPECT_EQ(labels[1].classes[index_of(1, 2.525f)], 1);
  // Views farther away than the window are not taken.
  fusion_config.window = 1.0;
  ViewFusion near_only(labeler, fusion_config);
  for (int k = 0; k < 2; ++k) {
    labels[k] = labeler.observe(scans[k], 10.0 * k);
    near_only.add(k, scans[k], poses.poses[k], 2.0 * k, labels[k]);
  }
  near_only.fuse(0, scans[0], near_only.bestFrames(0, scans[0]), labels[0]);
  EXPECT_EQ(labels[0].channels[0][index_of(0, 6.025f)], 90.0f);
  near_only.fuse(1, scans[1], near_only.bestFrames(1, scans[1]), labels[1]);
  EXPECT_TRUE(std::isnan(labels[1].channels[0][index_of(1, 2.525f)]));
}

}  // namespace
}  // namespace hazmap

#include "hazmap/properties/bag_images.hpp"

namespace hazmap {
namespace {

TEST(BagImages, RealMcapThermalTopicIsCentikelvinWithAHotSpot) {
  const auto bag = test::sharedData("sensors/mcap/velodyne-zstd-chunked.mcap");
  CameraCalibration cam = smallCamera(16, 12);
  cam.topic = "/thermal/image_raw";
  const auto images = readBagImages(bag, cam);
  ASSERT_EQ(images->stamps().size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const PropertyImage img = images->load(k, cam);
    int hot = 0, min_x = 99, max_x = -1, min_y = 99, max_y = -1;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const float v = img.at(x, y);
        if (std::abs(v - 76.85f) < 1e-3f) {
          ++hot;
          min_x = std::min(min_x, x), max_x = std::max(max_x, x), min_y = std::min(min_y, y), max_y = std::max(max_y, y);
        } else {
          EXPECT_NEAR(v, 26.85f, 1e-3f);  // 300 K
        }
      }
    EXPECT_EQ(hot, 9);  // a 3×3 spot of 350 K
    EXPECT_EQ(max_x - min_x, 2);
    EXPECT_EQ(max_y - min_y, 2);
    if (k > 0) EXPECT_GT(images->stamps()[k], images->stamps()[k - 1]);
  }
  // A camera calibrated for another size, a topic that is not an image, a topic that is absent.
  EXPECT_THROW(readBagImages(bag, smallCamera(16, 13), "/thermal/image_raw"), Error);
  EXPECT_THROW(readBagImages(bag, cam, "/odom"), Error);
  EXPECT_THROW(readBagImages(bag, cam, "/nope"), Error);
}

}  // namespace
}  // namespace hazmap
