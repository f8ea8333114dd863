#include "hazmap/properties/camera.hpp"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <set>
#include <sstream>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

const std::set<std::string> kKnownKeys = {
    "image_width", "image_height", "camera_name", "camera_matrix", "distortion_model",
    "distortion_coefficients", "rectification_matrix", "projection_matrix", "binning_x", "binning_y",
    "T_camera_lidar", "time_offset", "channel", "images", "topic"};

template <typename T>
T scalar(const YAML::Node& node, const std::string& where, const std::string& key) {
  if (!node || !node.IsScalar()) fail(where, "'" + key + "' is missing or not a single value");
  try {
    return node.as<T>();
  } catch (const YAML::Exception&) {
    fail(where, "bad value for '" + key + "'");
  }
}

YAML::Node required(const YAML::Node& root, const std::string& where, const std::string& key) {
  const YAML::Node n = root[key];
  if (!n) fail(where, "missing key '" + key + "'");
  return n;
}

/// A matrix given as {rows, cols, data: [...]}, a flat list, or a list of rows.
std::vector<double> matrixData(const YAML::Node& node, const std::string& where, const std::string& key,
                               std::size_t rows, std::size_t cols) {
  std::vector<double> data;
  const auto number = [&](const YAML::Node& n) { data.push_back(scalar<double>(n, where, key)); };
  if (node.IsMap()) {
    const YAML::Node d = node["data"];
    if (!d || !d.IsSequence()) fail(where, "'" + key + "' has no data list");
    if (node["rows"] && scalar<std::size_t>(node["rows"], where, key + ".rows") != rows)
      fail(where, "'" + key + ".rows' must be " + std::to_string(rows));
    if (node["cols"] && scalar<std::size_t>(node["cols"], where, key + ".cols") != cols)
      fail(where, "'" + key + ".cols' must be " + std::to_string(cols));
    for (const auto& n : d) number(n);
  } else if (node.IsSequence()) {
    for (const auto& n : node) {
      if (n.IsSequence())
        for (const auto& m : n) number(m);
      else
        number(n);
    }
  } else {
    fail(where, "'" + key + "' is not a matrix");
  }
  if (data.size() != rows * cols)
    fail(where, "'" + key + "' has " + std::to_string(data.size()) + " numbers, expected " +
                    std::to_string(rows * cols));
  for (double v : data)
    if (!std::isfinite(v)) fail(where, "'" + key + "' has a non-finite number");
  return data;
}

Eigen::Isometry3d rigidTransform(const std::vector<double>& d, const std::string& where) {
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) M(r, c) = d[4 * r + c];
  if ((M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9)
    fail(where, "'T_camera_lidar' last row must be 0 0 0 1");
  const Eigen::Matrix3d R = M.topLeftCorner<3, 3>();
  const double orthogonality = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-4 || R.determinant() < 0)
    fail(where, "'T_camera_lidar' rotation block is not a rotation (RᵀR ≠ I or det < 0)");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = projectToSO3(R);  // remove the rounding of a printed calibration
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

CameraIntrinsics intrinsicsFrom(const YAML::Node& root, const std::string& where) {
  CameraIntrinsics k;
  k.width = scalar<int>(required(root, where, "image_width"), where, "image_width");
  k.height = scalar<int>(required(root, where, "image_height"), where, "image_height");
  const auto K = matrixData(required(root, where, "camera_matrix"), where, "camera_matrix", 3, 3);
  if (K[1] != 0 || K[3] != 0 || K[6] != 0 || K[7] != 0 || K[8] != 1)
    fail(where, "'camera_matrix' must be [fx 0 cx; 0 fy cy; 0 0 1]");
  k.fx = K[0];
  k.cx = K[2];
  k.fy = K[4];
  k.cy = K[5];
  if (k.fx <= 0 || k.fy <= 0) fail(where, "'camera_matrix' focal length must be positive");
  const std::string model_name =
      root["distortion_model"] ? scalar<std::string>(root["distortion_model"], where, "distortion_model") : "none";
  const auto model = parseDistortionModel(model_name);
  if (!model)
    fail(where, "'distortion_model' " + model_name + " is not supported (plumb_bob, equidistant, none)");
  k.distortion = *model;
  const std::size_t expected = *model == DistortionModel::RadialTangential ? 5
                               : *model == DistortionModel::Equidistant    ? 4
                                                                           : 0;
  if (expected > 0) {
    const YAML::Node dn = required(root, where, "distortion_coefficients");
    const std::size_t n = dn.IsMap() && dn["data"] ? dn["data"].size() : dn.size();
    const auto D = matrixData(dn, where, "distortion_coefficients", 1, n);
    // ROS allows a plumb_bob with only k1 k2 p1 p2 (k3 = 0).
    if (D.size() != expected && !(*model == DistortionModel::RadialTangential && D.size() == 4))
      fail(where, "'distortion_coefficients' has " + std::to_string(D.size()) + " numbers, " + model_name +
                      " needs " + std::to_string(expected));
    for (std::size_t i = 0; i < D.size(); ++i) k.coeffs[i] = D[i];
  }
  return k;
}

PropertyChannel channelFrom(const YAML::Node& node, const std::string& where) {
  if (!node.IsMap()) fail(where, "'channel' must be a mapping (name, units, scale, offset, float_offset)");
  if (!node["name"]) fail(where, "missing key 'channel.name'");
  PropertyChannel ch = defaultChannel(scalar<std::string>(node["name"], where, "channel.name"));
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    if (key == "name") continue;
    if (key == "units") ch.units = scalar<std::string>(kv.second, where, "channel.units");
    else if (key == "scale") ch.scale = scalar<double>(kv.second, where, "channel.scale");
    else if (key == "offset") ch.offset = scalar<double>(kv.second, where, "channel.offset");
    else if (key == "float_offset") ch.float_offset = scalar<double>(kv.second, where, "channel.float_offset");
    else fail(where, "unknown key 'channel." + key + "'");
  }
  if (!std::isfinite(ch.scale) || ch.scale == 0 || !std::isfinite(ch.offset) || !std::isfinite(ch.float_offset))
    fail(where, "'channel' scale must be finite and non-zero, offsets finite");
  return ch;
}

std::string number(double v) {
  char buf[64];
  const auto res = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, res.ptr);
}

}  // namespace

PropertyChannel defaultChannel(const std::string& name) {
  PropertyChannel ch;
  ch.name = name;
  if (name == "temperature") return ch;  // centikelvin → °C
  ch.offset = 0.0;
  if (name == "nir_reflectance") {
    ch.units = "1";
    ch.scale = 1.0 / 65535.0;
  } else if (name == "dose_rate") {
    ch.units = "uSv/h";
    ch.scale = 0.01;
  } else {
    ch.units = "";
    ch.scale = 1.0;
  }
  return ch;
}

CameraCalibration parseCameraYaml(const std::string& yaml, const std::string& where,
                                  const std::filesystem::path& base_dir) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    fail(where, std::string("not valid YAML: ") + e.what());
  }
  if (!root.IsMap()) fail(where, "a camera calibration must be a YAML mapping");
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!kKnownKeys.count(key)) fail(where, "unknown key '" + key + "'");
  }
  CameraCalibration cam;
  cam.source = where;
  cam.model = CameraModel(intrinsicsFrom(root, where), where);
  if (root["camera_name"]) cam.name = scalar<std::string>(root["camera_name"], where, "camera_name");
  cam.T_camera_lidar =
      rigidTransform(matrixData(required(root, where, "T_camera_lidar"), where, "T_camera_lidar", 4, 4), where);
  if (root["time_offset"]) cam.time_offset = scalar<double>(root["time_offset"], where, "time_offset");
  if (!std::isfinite(cam.time_offset)) fail(where, "'time_offset' is not finite");
  cam.channel = channelFrom(required(root, where, "channel"), where);
  if (root["images"]) {
    const std::filesystem::path images = scalar<std::string>(root["images"], where, "images");
    cam.images = images.is_absolute() || base_dir.empty() ? images : (base_dir / images).lexically_normal();
  }
  if (root["topic"]) cam.topic = scalar<std::string>(root["topic"], where, "topic");
  return cam;
}

CameraCalibration readCameraYaml(const std::filesystem::path& path) {
  const std::filesystem::path dir = std::filesystem::absolute(path).parent_path();
  return parseCameraYaml(readTextFile(path), path.string(), dir);
}

std::string cameraYaml(const CameraCalibration& cam, const std::string& images_field) {
  const CameraIntrinsics& k = cam.model.intrinsics();
  std::ostringstream s;
  s << "# hazmap camera: ROS camera_info fields + T_camera_lidar, time_offset, channel\n"
    << "image_width: " << k.width << "\nimage_height: " << k.height << "\ncamera_name: " << cam.name << "\n"
    << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << number(k.fx) << ", 0, " << number(k.cx) << ", 0, "
    << number(k.fy) << ", " << number(k.cy) << ", 0, 0, 1]\n"
    << "distortion_model: " << toString(k.distortion) << "\n";
  const int n = k.distortion == DistortionModel::RadialTangential ? 5
                : k.distortion == DistortionModel::Equidistant    ? 4
                                                                  : 0;
  s << "distortion_coefficients:\n  rows: 1\n  cols: " << n << "\n  data: [";
  for (int i = 0; i < n; ++i) s << (i ? ", " : "") << number(k.coeffs[i]);
  s << "]\nT_camera_lidar:\n  rows: 4\n  cols: 4\n  data: [";
  const Eigen::Matrix4d M = cam.T_camera_lidar.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) s << (r || c ? ", " : "") << number(M(r, c));
  s << "]\ntime_offset: " << number(cam.time_offset) << "\n"
    << "channel: {name: " << cam.channel.name << ", units: '" << cam.channel.units << "', scale: "
    << number(cam.channel.scale) << ", offset: " << number(cam.channel.offset)
    << ", float_offset: " << number(cam.channel.float_offset) << "}\n";
  if (!images_field.empty()) s << "images: " << images_field << "\n";
  if (!cam.topic.empty()) s << "topic: " << cam.topic << "\n";
  return s.str();
}

}  // namespace hazmap
