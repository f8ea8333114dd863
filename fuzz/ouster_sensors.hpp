#pragma once
// The small Ouster sensors fuzz_ouster decodes packets of (modes 1..5), shared with the seed
// maker so the seeds are packets of exactly these sensors. Small so that every input builds its
// decoder (and XYZ table) quickly.
#include <string>
#include <vector>

#include "hazmap/sources/ouster.hpp"

namespace hazmap::fuzz {

/// 8 beams × 512 columns, 4 columns per packet (nested metadata layout).
inline std::string smallOusterJson(const std::string& profile) {
  return R"({"sensor_info": {"prod_line": "OS-0-32", "prod_sn": "992100000123", "initialization_id": 4242},
    "beam_intrinsics": {"beam_altitude_angles": [15, 11, 7, 3, -1, -5, -9, -13],
      "beam_azimuth_angles": [3, -3, 3, -3, 3, -3, 3, -3], "lidar_origin_to_beam_origin_mm": 27.67,
      "beam_to_lidar_transform": [1, 0, 0, 27.67, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},
    "lidar_intrinsics": {"lidar_to_sensor_transform": [-1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1, 36.18, 0, 0, 0, 1]},
    "lidar_data_format": {"pixels_per_column": 8, "columns_per_packet": 4, "columns_per_frame": 512,
      "column_window": [0, 511], "udp_profile_lidar": ")" + profile + R"("},
    "config_params": {"lidar_mode": "512x10", "udp_port_lidar": 7502}})";
}

/// 16 beams, 16 columns per packet, a column window through column 0 (flat metadata layout).
inline std::string windowedOusterJson() {
  std::string alt, az;
  for (int r = 0; r < 16; ++r) alt += (r ? ", " : "") + std::to_string(16 - 2 * r), az += (r ? ", " : "") + std::string(r % 2 ? "-2.1" : "2.1");
  return R"({"prod_line": "OS-1-16", "lidar_mode": "512x20", "beam_altitude_angles": [)" + alt +
         R"(], "beam_azimuth_angles": [)" + az + R"(], "lidar_origin_to_beam_origin_mm": 15.806,
    "data_format": {"pixels_per_column": 16, "columns_per_packet": 16, "columns_per_frame": 512,
      "column_window": [400, 100], "udp_profile_lidar": "RNG19_RFL8_SIG16_NIR16"}})";
}

/// Mode 1..5 → the sensor.
inline std::vector<OusterMetadata> fuzzOusterSensors() {
  std::vector<OusterMetadata> out{parseOusterMetadata(windowedOusterJson(), "windowed.json")};
  for (const char* p : {"LEGACY", "RNG19_RFL8_SIG16_NIR16", "RNG19_RFL8_SIG16_NIR16_DUAL", "RNG15_RFL8_NIR8"})
    out.push_back(parseOusterMetadata(smallOusterJson(p), "small.json"));
  return out;
}

}  // namespace hazmap::fuzz
