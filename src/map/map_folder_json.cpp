#include "map/map_folder_json.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace hazmap::map_folder_detail {

namespace {

nlohmann::json vec3(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

Eigen::Vector3d vec3From(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument("expected [x, y, z]");
  Eigen::Vector3d v(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  if (!v.allFinite()) throw std::invalid_argument("non-finite coordinate");
  return v;
}

}  // namespace

nlohmann::json poseJson(const Eigen::Isometry3d& pose) {
  nlohmann::json j = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) j.push_back(c < 3 ? pose.linear()(r, c) : pose.translation()(r));
  return j;
}

Eigen::Isometry3d poseFromJson(const nlohmann::json& j) {
  if (!j.is_array() || j.size() != 12) throw std::invalid_argument("a pose is 12 numbers (row-major 3x4)");
  Eigen::Matrix<double, 3, 4> m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = j[static_cast<std::size_t>(4 * r + c)].get<double>();
  if (!m.allFinite()) throw std::invalid_argument("non-finite pose");
  const Eigen::Matrix3d R = m.leftCols<3>();
  if (!(R.transpose() * R).isIdentity(1e-4) || R.determinant() < 0)
    throw std::invalid_argument("pose rotation is not a rotation");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = m.col(3);
  return T;
}

nlohmann::json landmarkJson(const PropertyLandmark& l) {
  nlohmann::json axes = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) axes.push_back(l.axes(r, c));
  nlohmann::json j = {{"class", l.class_id}, {"centroid", vec3(l.centroid)}, {"extent", vec3(l.extent)},
                      {"axes", axes}, {"box_min", vec3(l.box_min)}, {"box_max", vec3(l.box_max)},
                      {"points", l.point_count}, {"purity", l.purity}};
  if (l.has_property_value) j["mean_property"] = l.mean_property;
  return j;
}

PropertyLandmark landmarkFromJson(const nlohmann::json& j) {
  PropertyLandmark l;
  l.class_id = j.at("class").get<ClassId>();
  l.centroid = vec3From(j.at("centroid"));
  l.extent = vec3From(j.at("extent"));
  const auto& axes = j.at("axes");
  if (!axes.is_array() || axes.size() != 9) throw std::invalid_argument("landmark axes are 9 numbers");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) l.axes(r, c) = axes[static_cast<std::size_t>(3 * r + c)].get<double>();
  l.box_min = vec3From(j.at("box_min"));
  l.box_max = vec3From(j.at("box_max"));
  l.point_count = j.at("points").get<std::size_t>();
  l.purity = j.at("purity").get<double>();
  if (j.contains("mean_property")) {
    l.has_property_value = true;
    l.mean_property = j.at("mean_property").get<double>();
  }
  return l;
}

nlohmann::json keyframeJson(const MapKeyframe& k) {
  nlohmann::json landmarks = nlohmann::json::array();
  for (const auto& l : k.landmarks) landmarks.push_back(landmarkJson(l));
  return {{"frame", k.frame}, {"stamp", k.stamp}, {"pose", poseJson(k.pose)}, {"cloud", k.cloud},
          {"points", k.points}, {"landmarks", landmarks}};
}

MapKeyframe keyframeFromJson(const nlohmann::json& j) {
  MapKeyframe k;
  k.frame = j.at("frame").get<std::size_t>();
  k.stamp = j.at("stamp").get<double>();
  k.pose = poseFromJson(j.at("pose"));
  k.cloud = j.at("cloud").get<std::string>();
  k.points = j.at("points").get<std::size_t>();
  for (const auto& l : j.at("landmarks")) k.landmarks.push_back(landmarkFromJson(l));
  return k;
}

std::string hex64(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

std::uint64_t parseHex64(const std::string& text) {
  if (text.size() != 16 || text.find_first_not_of("0123456789abcdef") != std::string::npos)
    throw std::invalid_argument("checksum '" + text + "' is not 16 hex digits");
  return std::stoull(text, nullptr, 16);
}

}  // namespace hazmap::map_folder_detail
