// Issue 36 parts 4-6 below the CLI: compressed camera images (PNG keeps 16-bit counts, JPEG
// for RGB stand-ins), rig files, several cameras of one channel (the smallest footprint wins),
// simulated rigs, the map's per-channel fields. End to end: test_properties_sim.cpp.
#include <gtest/gtest.h>
#include <stb/stb_image_write.h>

#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/properties/camera_rig.hpp"
#include "hazmap/properties/labeler.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/sim/camera_sim.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

namespace fs = std::filesystem;

CameraCalibration camera(int w, int h, double f = 10) {
  CameraIntrinsics k;
  k.width = w;
  k.height = h;
  k.fx = k.fy = f;
  k.cx = (w - 1) / 2.0;
  k.cy = (h - 1) / 2.0;
  CameraCalibration cam;
  cam.model = CameraModel(k);
  cam.channel = defaultChannel("temperature");
  return cam;
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(CompressedImages, SixteenBitPngKeepsItsCountsAndJpegGivesLuminance) {
  Gray16 raw{3, 2, {0, 1, 29323, 35002, 65534, 65535}};
  CompressedImageMsg msg{{12.5, "thermal"}, "mono16; png compressed", encodePng16(raw)};
  const CameraCalibration cam = camera(3, 2);
  const PropertyImage img = imageFromCompressed(msg, cam, "bag: /thermal/image_raw message 0");
  EXPECT_EQ(img.stamp, 12.5);
  for (std::size_t i = 0; i < raw.pixels.size(); ++i)  // exactly raw·0.01 − 273.15, as mono16
    EXPECT_EQ(img.values[i], static_cast<float>(raw.pixels[i] * 0.01 - 273.15)) << i;
  msg.format = "png";  // image_transport's plain spelling
  EXPECT_EQ(imageFromCompressed(msg, cam, "bag").values, img.values);

  // JPEG, RGB: a red and a white half through Rec. 601 luminance as 8-bit counts.
  std::vector<std::uint8_t> rgb;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 3; ++c) rgb.push_back(x < 8 ? (c == 0 ? 255 : 0) : 255);
  CompressedImageMsg jpeg{{1.0, "rgb"}, "bgr8; jpeg compressed bgr8", {}};
  stbi_write_jpg_to_func(
      [](void* ctx, void* data, int size) {
        auto* out = static_cast<std::vector<std::uint8_t>*>(ctx);
        out->insert(out->end(), static_cast<std::uint8_t*>(data), static_cast<std::uint8_t*>(data) + size);
      },
      &jpeg.data, 16, 16, 3, rgb.data(), 100);
  CameraCalibration grey = camera(16, 16);
  grey.channel = defaultChannel("brightness");  // 1:1
  const PropertyImage j = imageFromCompressed(jpeg, grey, "bag");
  EXPECT_NEAR(j.at(2, 8), 0.299 * 255, 3.0);
  EXPECT_NEAR(j.at(13, 8), 255.0, 3.0);

  // A format hazmap cannot read, bytes that are not what the format says, another size.
  jpeg.format = "tiff";
  EXPECT_NE(errorOf([&] { imageFromCompressed(jpeg, grey, "b.mcap: /cam message 3"); })
                .find("b.mcap: /cam message 3: compressed image format 'tiff' is not supported"),
            std::string::npos);
  jpeg.format = "png";
  EXPECT_NE(errorOf([&] { imageFromCompressed(jpeg, grey, "b"); }).find("is not 'png'"), std::string::npos);
  jpeg.format = "jpeg";
  EXPECT_NE(errorOf([&] { imageFromCompressed(jpeg, camera(16, 15), "b"); }).find("calibrated for 16x15"),
            std::string::npos);
  jpeg.data.resize(40);  // truncated
  EXPECT_THROW(imageFromCompressed(jpeg, grey, "b"), Error);
}

TEST(CameraRigFiles, ListCameraFilesRelativeToTheRig) {
  const fs::path dir = test::scratchDir();
  const CameraCalibration cam = camera(4, 4);
  fs::create_directories(dir / "a");
  fs::create_directories(dir / "b");
  writeTextAtomically(dir / "a/camera.yaml", cameraYaml(cam, "."));
  writeTextAtomically(dir / "b/camera.yaml", cameraYaml(cam, "."));
  writeTextAtomically(dir / "rig.yaml", "cameras:\n  - a/camera.yaml\n  - b/camera.yaml\n");
  EXPECT_TRUE(isCameraRig(dir / "rig.yaml"));
  EXPECT_FALSE(isCameraRig(dir / "a/camera.yaml"));
  const auto files = expandCameraFiles({dir / "rig.yaml"});
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files[1], (dir / "b/camera.yaml").lexically_normal());
  // Bad rigs: one line naming the file and the problem.
  EXPECT_NE(errorOf([&] { parseCameraRig("cameras: []", "r.yaml", dir); }).find("r.yaml: 'cameras' must be a non-empty list"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { parseCameraRig("cameras: [a.yaml]\ncamras: 1", "r.yaml", dir); }).find("unknown key 'camras'"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { parseCameraRig("cameras: [[1]]", "r.yaml", dir); }).find("cameras[0] must be"), std::string::npos);
  EXPECT_NE(errorOf([&] { expandCameraFiles({dir / "rig.yaml", dir / "a/camera.yaml"}); }).find("camera given twice"),
            std::string::npos);
}

/// A wall x = 5 (y, z in [-1, 1]) and two forward cameras of one channel: camera 0 five metres
/// behind camera 1 (footprint 10 m/rad against 5), reading 90 °C against 20 °C.
struct TwoCameraWall {
  LabeledCloud wall;
  std::vector<CameraInput> cameras;
  TwoCameraWall() {
    for (int iy = -10; iy <= 10; ++iy)
      for (int iz = -10; iz <= 10; ++iz) wall.push_back({5.0f, 0.1f * iy, 0.1f * iz});
    for (int c = 0; c < 2; ++c) {
      CameraCalibration cam = camera(41, 41, 40);
      cam.name = c == 0 ? "far" : "near";
      Eigen::Isometry3d T_lidar_camera = Eigen::Isometry3d::Identity();
      T_lidar_camera.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
      T_lidar_camera.translation() = Eigen::Vector3d(c == 0 ? -5.0 : 0.0, 0, 0);
      cam.T_camera_lidar = T_lidar_camera.inverse();
      auto images = std::make_shared<MemoryImages>();
      PropertyImage img;
      img.width = img.height = 41;
      img.values.assign(41 * 41, c == 0 ? 90.0f : 20.0f);
      images->add(img);
      cameras.push_back({cam, images});
    }
  }
};

TEST(CameraRigs, APointSeenByTwoCamerasOfOneChannelTakesTheSmallerFootprint) {
  TwoCameraWall scene;
  const auto rules = PropertyRules::defaults({"temperature"}, ClassTable::defaults());
  LabelerConfig config;
  config.footprints = true;
  const PropertyLabeler labeler(scene.cameras, rules, config);
  ASSERT_EQ(labeler.channels().size(), 1u);
  EXPECT_EQ(labeler.camerasOfChannel(0), 2u);
  const ScanLabels l = labeler.label(scene.wall, 0.0);
  std::size_t near = 0, seen = 0;
  for (std::size_t i = 0; i < scene.wall.size(); ++i) {
    if (std::isnan(l.channels[0][i])) continue;
    ++seen;
    near += l.channels[0][i] == 20.0f && l.source_camera[0][i] == 1 && l.classes[i] == 0;
  }
  EXPECT_GT(seen, scene.wall.size() / 2);
  EXPECT_EQ(near, seen);  // every point the nearer, more frontal camera saw: its value
  // Without footprints (no view fusion), the first camera that saw a point gives its value.
  config.footprints = false;
  const ScanLabels first = PropertyLabeler(scene.cameras, rules, config).label(scene.wall, 0.0);
  std::size_t hot = 0;
  for (std::size_t i = 0; i < scene.wall.size(); ++i) hot += first.channels[0][i] == 90.0f && first.classes[i] == 1;
  EXPECT_EQ(hot, seen);
}

TEST(CameraRigs, SimulatedRingOfFourLooksAllAround) {
  sim::CameraSimConfig config;
  config.cameras = sim::CameraSimConfig::parseList("thermal,nir");
  config.rig = sim::CameraSimConfig::rigPreset("ring4");
  const auto placed = config.placedCameras();
  ASSERT_EQ(placed.size(), 8u);
  EXPECT_EQ(placed[1].name, "thermal_left");
  EXPECT_EQ(placed[5].kindName(), "nir");
  EXPECT_EQ(placed[1].channel().name, "temperature");
  EXPECT_EQ(placed[6].channel().name, "nir_reflectance");
  // Each camera's optical axis points where its placement says (LiDAR frame).
  const std::vector<Eigen::Vector3d> ahead = {{1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d axis = placed[k].cameraFromLidar().inverse().linear().col(2);
    EXPECT_LT((axis - ahead[k]).norm(), 1e-12) << placed[k].name;
    EXPECT_EQ(placed[k].hfov_deg, 90.0);
  }
  EXPECT_NO_THROW(config.validate("rig"));
  config.cameras = sim::CameraSimConfig::parseList("thermal,nir,gamma");  // 12 cameras
  EXPECT_NE(errorOf([&] { config.validate("rig"); }).find("12 cameras placed; at most 8"), std::string::npos);
  EXPECT_THROW(sim::CameraSimConfig::rigPreset("ring5"), Error);
  // Without a rig the cameras are as listed, forward camera untouched by the yaw.
  config.rig.clear();
  EXPECT_EQ(config.placedCameras().size(), 3u);
  EXPECT_EQ(config.placedCameras()[0].cameraFromLidar().matrix(), sim::SimCameraConfig::forName("thermal").cameraFromLidar().matrix());
}

TEST(MapChannelFields, PlyStoresEveryChannelAndHazardsJsonNamesTheCameras) {
  const fs::path dir = test::scratchDir();
  LabeledCloud cloud;
  cloud.push_back({0, 0, 0}, 1);
  cloud.push_back({1, 0, 0}, 0);
  PlyWriteOptions options;
  options.fields = {{"temperature", {80.0f, NAN}}, {"nir_reflectance", {0.6f, 0.05f}}};
  writePly(dir / "m.ply", cloud, options);
  const std::string text = readTextFile(dir / "m.ply");
  EXPECT_NE(text.find("property float temperature\nproperty float nir_reflectance\nend_header"), std::string::npos);
  options.fields[1].second.pop_back();
  EXPECT_NE(errorOf([&] { writePly(dir / "bad.ply", cloud, options); }).find("field 'nir_reflectance' needs"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "bad.ply"));
  const std::string json = hazardsJson({}, 0.1, 2, {{"temperature", {"thermal_front", "thermal_rear"}}});
  EXPECT_NE(json.find("\"cameras\": [\n        \"thermal_front\",\n        \"thermal_rear\""), std::string::npos) << json;
}

}  // namespace
}  // namespace hazmap
