// libFuzzer target: the properties stage's parsers. The first byte picks one:
//   0 camera.yaml (a calibration that parses must survive a write/read round trip),
//   1 class rules (evaluated on NaN and a few values), 2 PNG/TIFF images,
//   3 sensor_msgs/Image conversion (size, encoding, step and data from the input),
//   4 camera rig files (cameras: [files]), 5 sensor_msgs/CompressedImage (format + PNG/JPEG bytes).
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/camera_rig.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/properties/rules.hpp"

namespace {

void cameraYaml(const std::string& text) {
  hazmap::CameraCalibration cam;
  try {
    cam = hazmap::parseCameraYaml(text, "fuzz.yaml");
  } catch (const hazmap::Error&) {
    return;
  }
  try {
    const auto back = hazmap::parseCameraYaml(hazmap::cameraYaml(cam, ""), "round-trip");
    if (back.model.intrinsics().coeffs != cam.model.intrinsics().coeffs ||
        !back.T_camera_lidar.matrix().isApprox(cam.T_camera_lidar.matrix(), 1e-9))
      std::abort();
    const Eigen::Vector3d ray = cam.model.unproject({cam.model.width() / 2.0, cam.model.height() / 2.0});
    if (!ray.allFinite()) std::abort();
  } catch (const hazmap::Error& e) {
    std::fprintf(stderr, "round trip failed: %s\n", e.what());
    std::abort();
  }
}

void rules(const std::string& text) {
  try {
    const auto r = hazmap::PropertyRules::parse(text, "fuzz.yaml", hazmap::ClassTable::defaults());
    std::vector<float> values(r.variables().size(), NAN);
    (void)r.classify(values.data());
    for (float v : {-1.0f, 0.0f, 60.0f, 1e30f}) {
      std::fill(values.begin(), values.end(), v);
      (void)r.classify(values.data());
    }
  } catch (const hazmap::Error&) {
  }
}

void image(const std::uint8_t* data, std::size_t size) {
  try {
    (void)hazmap::decodeGray16(std::vector<std::uint8_t>(data, data + size), "fuzz.png");
  } catch (const hazmap::Error&) {
  }
}

void message(const std::uint8_t* data, std::size_t size) {
  if (size < 6) return;
  hazmap::ImageMsg msg;
  msg.width = data[0] % 9;
  msg.height = data[1] % 9;
  static const char* encodings[] = {"mono16", "mono8", "32FC1", "16UC1", "rgb8", "bgra8", "64FC1", "16SC1", "yuv422"};
  msg.encoding = encodings[data[2] % 9];
  msg.is_bigendian = data[3] & 1;
  msg.step = data[4] % 40;
  msg.data.assign(data + 6, data + size);
  hazmap::CameraIntrinsics k;
  k.width = std::max<int>(1, msg.width);
  k.height = std::max<int>(1, msg.height);
  k.fx = k.fy = 10;
  hazmap::CameraCalibration cam;
  try {
    cam.model = hazmap::CameraModel(k);
    (void)hazmap::imageFromMessage(msg, cam, "fuzz");
  } catch (const hazmap::Error&) {
  }
}

void rig(const std::string& text) {
  try {
    const auto files = hazmap::parseCameraRig(text, "rig.yaml", "/base");
    if (files.empty()) std::abort();  // a rig that parses lists at least one camera
  } catch (const hazmap::Error&) {
  }
}

void compressed(const std::uint8_t* data, std::size_t size) {
  if (size < 3) return;
  static const char* formats[] = {"png", "jpeg", "mono16; png compressed", "bgr8; jpeg compressed bgr8", "", "tiff"};
  hazmap::CompressedImageMsg msg{{}, formats[data[0] % 6], std::vector<std::uint8_t>(data + 2, data + size)};
  hazmap::CameraIntrinsics k;
  k.width = 1 + data[1] % 16;
  k.height = 1 + (data[1] >> 4);
  k.fx = k.fy = 10;
  hazmap::CameraCalibration cam;
  try {
    cam.model = hazmap::CameraModel(k);
    const auto img = hazmap::imageFromCompressed(msg, cam, "fuzz");
    if (img.values.size() != static_cast<std::size_t>(k.width) * k.height) std::abort();
  } catch (const hazmap::Error&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  switch (data[0] % 6) {
    case 0: cameraYaml(text); break;
    case 1: rules(text); break;
    case 2: image(data + 1, size - 1); break;
    case 3: message(data + 1, size - 1); break;
    case 4: rig(text); break;
    default: compressed(data + 1, size - 1); break;
  }
  return 0;
}
