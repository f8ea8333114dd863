// Ouster metadata JSON: the flat layout (firmware ≤ 2.3, ouster_ros ≤ 0.8: beam angles,
// lidar_mode, data_format, ... at the top level) and the nested one of later firmware
// (sensor_info, beam_intrinsics, lidar_intrinsics, imu_intrinsics, lidar_data_format,
// config_params). Defaults for absent optional fields follow the sensor's documentation.
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ouster.hpp"

namespace hazmap {
namespace {

using nlohmann::json;

/// Where the fields live: the flat layout keeps everything at the top level.
struct Sections {
  const json* sensor_info;
  const json* beam;
  const json* lidar;
  const json* imu;
  const json* format;  // may be null (very old metadata: only angles and lidar_mode)
  const json* config;
};

const json* objectOr(const json& root, const char* key, const json* fallback) {
  const auto it = root.find(key);
  return it != root.end() && it->is_object() ? &*it : fallback;
}

const json* find(const json* section, const char* key) {
  if (!section) return nullptr;
  const auto it = section->find(key);
  return it == section->end() || it->is_null() ? nullptr : &*it;
}

std::string text(const json* value, const std::string& where, const char* key) {
  if (!value) return {};
  if (value->is_string()) return value->get<std::string>();
  if (value->is_number_integer()) return std::to_string(value->get<std::int64_t>());
  fail(where, std::string("field '") + key + "' is not a string");
}

double number(const json& value, const std::string& where, const char* key) {
  if (!value.is_number()) fail(where, std::string("field '") + key + "' is not a number");
  const double v = value.get<double>();
  if (!std::isfinite(v)) fail(where, std::string("field '") + key + "' is not finite");
  return v;
}

std::uint32_t count(const json* value, const std::string& where, const char* key,
                    std::uint32_t fallback, std::uint32_t max) {
  if (!value) return fallback;
  if (!value->is_number_integer() || value->get<std::int64_t>() < 1 || value->get<std::int64_t>() > max)
    fail(where, std::string("field '") + key + "' must be an integer in 1.." + std::to_string(max));
  return value->get<std::uint32_t>();
}

std::vector<double> numbers(const json* value, const std::string& where, const char* key) {
  if (!value) fail(where, std::string("missing field '") + key + "'");
  if (!value->is_array()) fail(where, std::string("field '") + key + "' is not an array");
  std::vector<double> out;
  out.reserve(value->size());
  for (const json& v : *value) out.push_back(number(v, where, key));
  return out;
}

Eigen::Matrix4d matrix(const json* value, const Eigen::Matrix4d& fallback, const std::string& where,
                       const char* key) {
  if (!value) return fallback;
  const std::vector<double> v = numbers(value, where, key);
  if (v.size() != 16) fail(where, std::string("field '") + key + "' must hold 16 numbers (a 4×4 row-major matrix)");
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = v[static_cast<std::size_t>(4 * r + c)];
  if (m.row(3) != Eigen::RowVector4d(0, 0, 0, 1) ||
      (m.topLeftCorner<3, 3>().transpose() * m.topLeftCorner<3, 3>() - Eigen::Matrix3d::Identity()).norm() > 1e-3)
    fail(where, std::string("field '") + key + "' is not a rigid transform");
  return m;
}

OusterProfile profileOf(const std::string& name, const std::string& where) {
  if (name.empty() || name == "LEGACY") return OusterProfile::Legacy;
  if (name == "RNG19_RFL8_SIG16_NIR16") return OusterProfile::Rng19Rfl8Sig16Nir16;
  if (name == "RNG19_RFL8_SIG16_NIR16_DUAL") return OusterProfile::Rng19Rfl8Sig16Nir16Dual;
  if (name == "RNG15_RFL8_NIR8") return OusterProfile::Rng15Rfl8Nir8;
  fail(where, "udp_profile_lidar '" + name + "' is not supported (LEGACY, RNG19_RFL8_SIG16_NIR16, "
              "RNG19_RFL8_SIG16_NIR16_DUAL, RNG15_RFL8_NIR8 are)");
}

/// "1024x10" → columns 1024, 10 Hz.
void parseLidarMode(OusterMetadata& m, const std::string& where) {
  unsigned columns = 0, rate = 0;
  char x = 0, extra = 0;
  std::istringstream in(m.lidar_mode);
  if (!(in >> columns >> x >> rate) || x != 'x' || (in >> extra) ||
      (columns != 512 && columns != 1024 && columns != 2048 && columns != 4096) ||
      (rate != 5 && rate != 10 && rate != 20))
    fail(where, "lidar_mode '" + m.lidar_mode + "' is not one of 512x10, 512x20, 1024x10, 1024x20, 2048x10, 4096x5");
  m.columns_per_frame = columns;
  m.scan_rate_hz = rate;
}

/// ouster-sdk's defaults for metadata that predates a field.
double defaultBeamOrigin(const std::string& prod_line) {
  if (prod_line.rfind("OS-0-", 0) == 0) return 27.67;
  if (prod_line.rfind("OS-1-", 0) == 0) return 15.806;
  if (prod_line.rfind("OS-2-", 0) == 0) return 13.762;
  return 12.163;  // first-generation OS-1
}

Eigen::Matrix4d defaultLidarToSensor() {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m(0, 0) = m(1, 1) = -1.0;
  m(2, 3) = 36.18;
  return m;
}

Eigen::Matrix4d defaultImuToSensor() {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRightCorner<3, 1>() << 6.253, -11.775, 7.645;
  return m;
}

void parseFormat(OusterMetadata& m, const Sections& s, const std::string& where) {
  m.lidar_mode = text(find(s.config, "lidar_mode"), where, "lidar_mode");
  if (!m.lidar_mode.empty()) parseLidarMode(m, where);
  const json* f = s.format;
  const std::uint32_t columns = count(find(f, "columns_per_frame"), where, "columns_per_frame", m.columns_per_frame, 4096);
  if (columns == 0) fail(where, "missing field 'lidar_mode' (or data_format.columns_per_frame)");
  if (m.columns_per_frame != 0 && columns != m.columns_per_frame)
    fail(where, "columns_per_frame " + std::to_string(columns) + " does not match lidar_mode " + m.lidar_mode);
  m.columns_per_frame = columns;
  // The data format describes the packets; the sensor's configuration says the same and is the
  // fallback when a recorder left the data format's entry out.
  const auto either = [&](const char* key) { const json* v = find(f, key); return v ? v : find(s.config, key); };
  m.columns_per_packet = count(either("columns_per_packet"), where, "columns_per_packet", 16, columns);
  m.profile = profileOf(text(either("udp_profile_lidar"), where, "udp_profile_lidar"), where);
  if (m.scan_rate_hz == 0.0)
    if (const json* fps = find(f, "fps")) m.scan_rate_hz = number(*fps, where, "fps");
  m.pixels_per_column = count(find(f, "pixels_per_column"), where, "pixels_per_column",
                              static_cast<std::uint32_t>(m.beam_altitude_deg.size()), 1024);
  m.column_window_first = 0;
  m.column_window_last = columns - 1;
  if (const json* w = find(f, "column_window")) {
    const std::vector<double> v = numbers(w, where, "column_window");
    if (v.size() != 2 || v[0] < 0 || v[1] < 0 || v[0] >= columns || v[1] >= columns ||
        v[0] != std::floor(v[0]) || v[1] != std::floor(v[1]))
      fail(where, "column_window must be two column indices below " + std::to_string(columns));
    m.column_window_first = static_cast<std::uint32_t>(v[0]);
    m.column_window_last = static_cast<std::uint32_t>(v[1]);
  }
  if (const json* shift = find(f, "pixel_shift_by_row"))
    for (double v : numbers(shift, where, "pixel_shift_by_row")) m.pixel_shift_by_row.push_back(static_cast<int>(v));
  m.pixel_shift_by_row.resize(m.pixels_per_column, 0);
}

void parseBeams(OusterMetadata& m, const Sections& s, const std::string& where) {
  m.beam_altitude_deg = numbers(find(s.beam, "beam_altitude_angles"), where, "beam_altitude_angles");
  m.beam_azimuth_deg = numbers(find(s.beam, "beam_azimuth_angles"), where, "beam_azimuth_angles");
  if (m.beam_altitude_deg.empty() || m.beam_altitude_deg.size() != m.beam_azimuth_deg.size())
    fail(where, "beam_altitude_angles (" + std::to_string(m.beam_altitude_deg.size()) +
                    ") and beam_azimuth_angles (" + std::to_string(m.beam_azimuth_deg.size()) +
                    ") must be non-empty and of equal length");
  for (std::size_t i = 0; i < m.beam_altitude_deg.size(); ++i)
    if (std::abs(m.beam_altitude_deg[i]) > 90.0 || std::abs(m.beam_azimuth_deg[i]) > 180.0)
      fail(where, "beam " + std::to_string(i) + " has an impossible angle");
  const json* origin = find(s.beam, "lidar_origin_to_beam_origin_mm");
  m.lidar_origin_to_beam_origin_mm = origin ? number(*origin, where, "lidar_origin_to_beam_origin_mm")
                                            : defaultBeamOrigin(m.prod_line);
  Eigen::Matrix4d beam_default = Eigen::Matrix4d::Identity();
  beam_default(0, 3) = m.lidar_origin_to_beam_origin_mm;
  m.beam_to_lidar = matrix(find(s.beam, "beam_to_lidar_transform"), beam_default, where, "beam_to_lidar_transform");
  m.lidar_to_sensor = matrix(find(s.lidar, "lidar_to_sensor_transform"), defaultLidarToSensor(), where,
                             "lidar_to_sensor_transform");
  m.imu_to_sensor = matrix(find(s.imu, "imu_to_sensor_transform"), defaultImuToSensor(), where,
                           "imu_to_sensor_transform");
}

std::uint16_t port(const json* value, const std::string& where, const char* key) {
  if (!value) return 0;
  if (!value->is_number_integer() || value->get<std::int64_t>() < 0 || value->get<std::int64_t>() > 65535)
    fail(where, std::string("field '") + key + "' is not a UDP port");
  return value->get<std::uint16_t>();
}

}  // namespace

OusterMetadata parseOusterMetadata(std::string_view text_in, const std::string& where) {
  json root;
  try {
    root = json::parse(text_in);
  } catch (const json::exception& e) {
    fail(where, std::string("not valid JSON: ") + e.what());
  }
  if (!root.is_object()) fail(where, "Ouster metadata must be a JSON object");
  OusterMetadata m;
  m.nested_layout = root.contains("beam_intrinsics") || root.contains("sensor_info");
  const json* top = &root;
  const Sections s = m.nested_layout
      ? Sections{objectOr(root, "sensor_info", nullptr), objectOr(root, "beam_intrinsics", nullptr),
                 objectOr(root, "lidar_intrinsics", nullptr), objectOr(root, "imu_intrinsics", nullptr),
                 objectOr(root, "lidar_data_format", nullptr), objectOr(root, "config_params", nullptr)}
      : Sections{top, top, top, top, objectOr(root, "data_format", nullptr), top};
  m.prod_line = text(find(s.sensor_info, "prod_line"), where, "prod_line");
  m.firmware = text(find(s.sensor_info, "build_rev"), where, "build_rev");
  m.serial = text(find(s.sensor_info, "prod_sn"), where, "prod_sn");
  if (const json* id = find(s.sensor_info, "initialization_id")) {
    if (!id->is_number_unsigned()) fail(where, "field 'initialization_id' is not an unsigned integer");
    m.initialization_id = id->get<std::uint64_t>();
  }
  parseBeams(m, s, where);
  parseFormat(m, s, where);
  if (m.pixels_per_column != m.beam_altitude_deg.size())
    fail(where, "pixels_per_column " + std::to_string(m.pixels_per_column) + " does not match the " +
                    std::to_string(m.beam_altitude_deg.size()) + " beam angles");
  m.udp_port_lidar = port(find(s.config, "udp_port_lidar"), where, "udp_port_lidar");
  m.udp_port_imu = port(find(s.config, "udp_port_imu"), where, "udp_port_imu");
  if (m.lidarPacketSize() > 65507) fail(where, "a lidar packet of this format would exceed a UDP datagram");
  return m;
}

OusterMetadata readOusterMetadata(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open the Ouster metadata file");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return parseOusterMetadata(buffer.str(), path.string());
}

std::optional<std::filesystem::path> findOusterMetadata(const std::filesystem::path& capture) {
  const std::string name = capture.stem().string();
  std::optional<std::filesystem::path> best;
  std::size_t best_length = 0;
  std::error_code ec;
  const auto folder = capture.has_parent_path() ? capture.parent_path() : std::filesystem::path(".");
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!entry.is_regular_file(ec) || entry.path().extension() != ".json") continue;
    const std::string stem = entry.path().stem().string();
    if (stem.size() > best_length && name.compare(0, stem.size(), stem) == 0) {
      best = entry.path();
      best_length = stem.size();
    }
  }
  return best;
}

std::string toString(OusterProfile profile) {
  switch (profile) {
    case OusterProfile::Legacy: return "LEGACY";
    case OusterProfile::Rng19Rfl8Sig16Nir16: return "RNG19_RFL8_SIG16_NIR16";
    case OusterProfile::Rng19Rfl8Sig16Nir16Dual: return "RNG19_RFL8_SIG16_NIR16_DUAL";
    case OusterProfile::Rng15Rfl8Nir8: return "RNG15_RFL8_NIR8";
  }
  return "?";
}

std::uint32_t OusterMetadata::columnsInWindow() const {
  if (column_window_last >= column_window_first) return column_window_last - column_window_first + 1;
  return columns_per_frame - column_window_first + column_window_last + 1;  // wraps through 0
}

std::string OusterMetadata::describe() const {
  return "Ouster " + (prod_line.empty() ? std::string("OS") : prod_line) + " " +
         std::to_string(columns_per_frame) + "x" + std::to_string(static_cast<int>(scan_rate_hz)) +
         " " + toString(profile) + " (" + std::to_string(pixels_per_column) + " beams)";
}

}  // namespace hazmap
