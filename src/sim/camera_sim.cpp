#include "hazmap/sim/camera_sim.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/sim/random.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

namespace fs = std::filesystem;

SimCameraConfig SimCameraConfig::forName(const std::string& name) {
  SimCameraConfig c;
  c.name = name;
  if (name == "thermal") {
    // Background at the simulator's ambient 20 °C; heat sources at 80 °C, clearly above the
    // default heat rule's 60 °C (a hot pump or steam pipe). NETD 50 mK per pixel.
    c.background = 20.0;
    c.region_value = 80.0;
    c.noise_sigma = 0.05;
  } else if (name == "nir") {
    // Dry concrete reflects ~0.6 of near-infrared light, a water film ~0.05.
    c.background = 0.6;
    c.region_value = 0.05;
    c.noise_sigma = 0.01;
    c.position = {0.05, 0.1, 0.1};
    c.pitch_deg = 15.0;  // looks down at the floor ahead, where puddles are
  } else if (name == "gamma") {
    // Background dose rate 0.2 µSv/h, hot spots 50 µSv/h; counting noise.
    c.background = 0.2;
    c.region_value = 50.0;
    c.noise_sigma = 0.1;
    c.position = {0.05, -0.1, 0.1};
  } else {
    fail("--cameras", "unknown camera '" + name + "' (known: thermal, nir, gamma)");
  }
  return c;
}

PropertyChannel SimCameraConfig::channel() const {
  const std::string& name = kindName();
  if (name == "nir") return defaultChannel("nir_reflectance");
  if (name == "gamma") return defaultChannel("dose_rate");
  return defaultChannel("temperature");
}

void SimCameraConfig::validate(const std::string& where) const {
  const std::string& k = kindName();
  if (k != "thermal" && k != "nir" && k != "gamma") fail(where, "unknown camera kind '" + k + "'");
  if (name.empty() || name.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-") !=
                          std::string::npos)
    fail(where, "camera name '" + name + "' must be letters, digits, - and _ (it names a folder)");
  if (!(std::abs(yaw_deg) <= 360)) fail(where, "camera yaw_deg must be in [-360, 360]");
  if (width < 2 || height < 2 || width > 8192 || height > 8192) fail(where, "camera size must be 2..8192 pixels");
  if (!(hfov_deg > 1 && hfov_deg < 170)) fail(where, "camera hfov_deg must be in (1, 170)");
  if (!(noise_sigma >= 0) || !std::isfinite(background) || !std::isfinite(region_value) || !position.allFinite())
    fail(where, "camera values must be finite, noise >= 0");
}

CameraIntrinsics SimCameraConfig::intrinsics() const {
  CameraIntrinsics k;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 0.5 * width / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  k.cx = 0.5 * (width - 1);
  k.cy = 0.5 * (height - 1);
  k.distortion = DistortionModel::RadialTangential;
  k.coeffs = {k1, k2, 0.0, 0.0, 0.0};
  return k;
}

Eigen::Isometry3d SimCameraConfig::cameraFromLidar() const {
  Eigen::Matrix3d optical;  // columns: camera x (right), y (down), z (forward) in the LiDAR frame
  optical << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d pitch = Eigen::AngleAxisd(pitch_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix();
  Eigen::Isometry3d T_lidar_camera = Eigen::Isometry3d::Identity();
  T_lidar_camera.linear() = pitch * optical;
  // Yaw only when set: an identity product could still round the forward camera's matrix.
  if (yaw_deg != 0.0) T_lidar_camera.linear() = Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * T_lidar_camera.linear();
  T_lidar_camera.translation() = position;
  return T_lidar_camera.inverse();
}

std::vector<RigPlacement> CameraSimConfig::rigPreset(const std::string& name) {
  if (name == "ring4") return {{"front", 0, 90}, {"left", 90, 90}, {"rear", 180, 90}, {"right", -90, 90}};
  if (name == "front-rear") return {{"front", 0, 0}, {"rear", 180, 0}};
  fail("--camera-rig", "unknown rig '" + name + "' (known: ring4, front-rear, or a rig YAML)");
}

std::vector<SimCameraConfig> CameraSimConfig::placedCameras() const {
  if (rig.empty()) return cameras;
  std::vector<SimCameraConfig> out;
  for (const SimCameraConfig& c : cameras)
    for (const RigPlacement& r : rig) {
      SimCameraConfig placed = c;
      placed.kind = c.kindName();
      placed.name = c.name + "_" + r.name;
      placed.yaw_deg = c.yaw_deg + r.yaw_deg;
      if (r.hfov_deg > 0) placed.hfov_deg = r.hfov_deg;
      // The mount turns with the camera (a ring of cameras around the LiDAR's mast).
      placed.position = Eigen::AngleAxisd(r.yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * c.position;
      out.push_back(std::move(placed));
    }
  return out;
}

void CameraSimConfig::validate(const std::string& where) const {
  for (const RigPlacement& r : rig)
    if (r.name.empty() || !(std::abs(r.yaw_deg) <= 360) || !(r.hfov_deg >= 0 && r.hfov_deg < 170))
      fail(where, "rig placement '" + r.name + "' needs a name, yaw_deg in [-360, 360], hfov_deg in [0, 170)");
  const std::vector<SimCameraConfig> placed = placedCameras();
  // Each camera's noise stream is frame·8 + its index (RngStream::Camera).
  if (placed.size() > 8) fail(where, std::to_string(placed.size()) + " cameras placed; at most 8");
  for (const auto& c : placed) c.validate(where);
  for (std::size_t i = 0; i < placed.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (placed[i].name == placed[j].name) fail(where, "camera '" + placed[i].name + "' given twice");
  if (!(calibration_error_deg >= 0 && calibration_error_m >= 0 && std::isfinite(time_offset)) ||
      calibration_error_deg > 45 || calibration_error_m > 1)
    fail(where, "calibration error must be in [0, 45] deg and [0, 1] m; time offset finite");
}

std::vector<SimCameraConfig> CameraSimConfig::parseList(const std::string& list) {
  std::vector<SimCameraConfig> out;
  std::stringstream s(list);
  std::string name;
  while (std::getline(s, name, ','))
    if (!name.empty()) out.push_back(SimCameraConfig::forName(name));
  return out;
}

void CameraSimConfig::parseCalibrationError(const std::string& text) {
  std::stringstream s(text);
  std::string part;
  bool angle = false, distance = false;
  while (std::getline(s, part, ',')) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(part, &used);
    } catch (const std::logic_error&) {
      fail("--calibration-error", "'" + part + "' is not a number with a unit (e.g. 1deg,2cm)");
    }
    const std::string unit = part.substr(used);
    if (unit == "deg") calibration_error_deg = v, angle = true;
    else if (unit == "rad") calibration_error_deg = v * 180.0 / M_PI, angle = true;
    else if (unit == "m") calibration_error_m = v, distance = true;
    else if (unit == "cm") calibration_error_m = v / 100.0, distance = true;
    else if (unit == "mm") calibration_error_m = v / 1000.0, distance = true;
    else fail("--calibration-error", "unit of '" + part + "' must be deg, rad, m, cm or mm");
  }
  if (!angle && !distance) fail("--calibration-error", "expected e.g. 1deg,2cm");
}

CameraCalibration writtenCalibration(const SimCameraConfig& camera, const CameraSimConfig& config,
                                     std::uint64_t seed, std::size_t index) {
  CameraCalibration cal;
  cal.name = camera.name;
  cal.model = CameraModel(camera.intrinsics(), "simulated camera " + camera.name);
  cal.channel = camera.channel();
  Eigen::Isometry3d T = camera.cameraFromLidar();
  Rng rng(seed, RngStream::Calibration, index);
  const auto randomUnit = [&] {
    Eigen::Vector3d v(rng.normal(), rng.normal(), rng.normal());
    return Eigen::Vector3d(v.normalized());
  };
  const Eigen::Vector3d axis = randomUnit(), direction = randomUnit();
  Eigen::Isometry3d error = Eigen::Isometry3d::Identity();
  error.linear() = Eigen::AngleAxisd(config.calibration_error_deg * M_PI / 180.0, axis).toRotationMatrix();
  error.translation() = config.calibration_error_m * direction;
  cal.T_camera_lidar = error * T;
  cal.time_offset = config.time_offset;
  return cal;
}

CameraRenderer::CameraRenderer(const Simulator& sim, SimCameraConfig camera, std::size_t camera_index)
    : sim_(sim), camera_(std::move(camera)), index_(camera_index) {
  camera_.validate("camera " + camera_.name);
  const CameraModel model(camera_.intrinsics(), "simulated camera " + camera_.name);
  rays_.resize(static_cast<std::size_t>(camera_.width) * camera_.height);
  for (int y = 0; y < camera_.height; ++y)
    for (int x = 0; x < camera_.width; ++x)
      rays_[static_cast<std::size_t>(y) * camera_.width + x] = model.unproject(Eigen::Vector2d(x, y)).cast<float>();
  const PropertyKind kind = camera_.kindName() == "thermal" ? PropertyKind::Heat
                            : camera_.kindName() == "nir"   ? PropertyKind::Water
                                                      : PropertyKind::Radiation;
  for (ClassId id : sim.classTable().ids())
    if (sim.classTable().at(id).kind == kind) region_classes_.push_back(id);
}

namespace {

/// 3×3 binomial blur ([1 2 1]/4 in each direction), borders clamped.
void blur3(std::vector<float>& img, int w, int h) {
  std::vector<float> tmp(img.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float* r = &img[static_cast<std::size_t>(y) * w];
      tmp[static_cast<std::size_t>(y) * w + x] = 0.25f * r[std::max(x - 1, 0)] + 0.5f * r[x] + 0.25f * r[std::min(x + 1, w - 1)];
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      img[static_cast<std::size_t>(y) * w + x] = 0.25f * tmp[static_cast<std::size_t>(std::max(y - 1, 0)) * w + x] +
                                                 0.5f * tmp[static_cast<std::size_t>(y) * w + x] +
                                                 0.25f * tmp[static_cast<std::size_t>(std::min(y + 1, h - 1)) * w + x];
}

}  // namespace

std::vector<float> CameraRenderer::renderValues(std::size_t frame) const {
  const Eigen::Isometry3d T_world_camera = sim_.worldPoses().at(frame) * camera_.cameraFromLidar().inverse();
  const Eigen::Matrix3f R = T_world_camera.linear().cast<float>();
  const Eigen::Vector3f origin = T_world_camera.translation().cast<float>();
  std::vector<Eigen::Vector3f> dirs(rays_.size());
  for (std::size_t i = 0; i < rays_.size(); ++i) dirs[i] = R * rays_[i];
  std::vector<RayHit> hits;
  sim_.caster().cast(origin, dirs, 0.0f, static_cast<float>(sim_.config().sensor.max_range), hits);
  std::vector<float> values(rays_.size(), static_cast<float>(camera_.background));
  for (std::size_t i = 0; i < hits.size(); ++i) {
    if (!hits[i].hit()) continue;
    const Eigen::Vector3d p = (origin + hits[i].distance * dirs[i]).cast<double>();
    const ClassId c = sim_.scene().classAt(p);
    if (c != 0 && std::find(region_classes_.begin(), region_classes_.end(), c) != region_classes_.end())
      values[i] = static_cast<float>(camera_.region_value);
  }
  if (camera_.blur) blur3(values, camera_.width, camera_.height);
  Rng rng(sim_.config().seed, RngStream::Camera, frame * 8 + index_);
  for (float& v : values) v += static_cast<float>(rng.normal(camera_.noise_sigma));
  return values;
}

Gray16 CameraRenderer::render(std::size_t frame) const {
  const std::vector<float> values = renderValues(frame);
  const PropertyChannel ch = camera_.channel();
  Gray16 img;
  img.width = camera_.width;
  img.height = camera_.height;
  img.pixels.resize(values.size());
  for (std::size_t i = 0; i < values.size(); ++i)
    img.pixels[i] = static_cast<std::uint16_t>(std::clamp(std::lround((values[i] - ch.offset) / ch.scale), 0L, 65535L));
  return img;
}

void writeCameraImages(const Simulator& sim, const CameraSimConfig& config, const fs::path& dir) {
  config.validate("cameras");
  std::ostringstream times;
  times.precision(9);
  for (std::size_t i = 0; i < sim.frames(); ++i) times << sim.samples()[i].time << "\n";
  const std::vector<SimCameraConfig> placed = config.placedCameras();
  for (std::size_t c = 0; c < placed.size(); ++c) {
    const SimCameraConfig& cam = placed[c];
    const fs::path folder = dir / "cameras" / cam.name;
    fs::create_directories(folder);
    const CameraRenderer renderer(sim, cam, c);
    tbb::parallel_for(std::size_t(0), sim.frames(), [&](std::size_t i) {
      char name[32];
      std::snprintf(name, sizeof name, "%06zu.png", i);
      writePng16(folder / name, renderer.render(i));
    });
    writeTextAtomically(folder / "times.txt", times.str());
    writeTextAtomically(folder / "camera.yaml", cameraYaml(writtenCalibration(cam, config, sim.config().seed, c), "."));
  }
  if (config.rig.empty()) return;
  std::string rig = "# the simulated camera rig: hazmap label SEQ --camera cameras/rig.yaml\ncameras:\n";
  for (const SimCameraConfig& cam : placed) rig += "  - " + cam.name + "/camera.yaml\n";
  writeTextAtomically(dir / "cameras" / "rig.yaml", rig);
}

}  // namespace hazmap::sim
