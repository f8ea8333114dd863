#include "hazmap/sim/velodyne_packets.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"

namespace hazmap::sim {

namespace {

constexpr int kBlocks = 12, kLasers = 16;
constexpr double kRevolution = 0.1;   // s, 600 rpm
constexpr double kDistanceUnit = 0.002;  // m per count

void put16(std::uint8_t* p, std::uint32_t v) {  // little endian, as the sensor sends
  p[0] = static_cast<std::uint8_t>(v & 0xff);
  p[1] = static_cast<std::uint8_t>((v >> 8) & 0xff);
}

/// The VLP-16's laser ids interleave elevations: lasers 0, 2, …, 14 point at -15°, -13°, …, -1°,
/// lasers 1, 3, …, 15 at 1°, 3°, …, 15°.
int laserOfChannel(int channel) { return channel < 8 ? 2 * channel : 2 * (channel - 8) + 1; }

struct Return {
  std::uint16_t range = 0;
  std::uint8_t intensity = 0;
};

/// The returns on the sensor's grid, indexed [Velodyne column][laser]; the Velodyne azimuth turns
/// clockwise seen from above, the simulator's counter-clockwise.
std::vector<std::array<Return, kLasers>> grid(const LabeledCloud& scan, const LidarConfig& lidar) {
  std::vector<std::array<Return, kLasers>> g(static_cast<std::size_t>(lidar.columns));
  const double step = lidar.azimuthStepDeg();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d p = scan.points[i].cast<double>();
    const double r = p.norm();
    const double counts = std::round(r / kDistanceUnit);
    if (!(r > 0) || counts >= 65535) continue;
    const double elevation = std::asin(p.z() / r) * 180.0 / M_PI;
    const int channel = static_cast<int>(std::lround((elevation - lidar.min_elevation_deg) / 2.0));
    if (channel < 0 || channel >= kLasers) continue;
    double azimuth = -std::atan2(p.y(), p.x()) * 180.0 / M_PI;  // clockwise from +x
    if (azimuth < 0) azimuth += 360.0;
    const auto column = static_cast<std::size_t>(std::lround(azimuth / step)) % g.size();
    const float intensity = scan.intensity.size() == scan.size() ? scan.intensity[i] : 0.0f;
    g[column][laserOfChannel(channel)] = {static_cast<std::uint16_t>(counts),
                                           static_cast<std::uint8_t>(std::clamp(intensity * 255.0f, 0.0f, 255.0f))};
  }
  return g;
}

}  // namespace

void checkVlp16Layout(const LidarConfig& lidar, const std::string& where) {
  if (lidar.channels != kLasers || lidar.min_elevation_deg != -15.0 || lidar.max_elevation_deg != 15.0 ||
      lidar.columns <= 0 || lidar.columns % (2 * kBlocks) != 0)
    fail(where, "Velodyne packets need the VLP-16's layout: 16 channels from -15 to 15 deg and a multiple of 24 "
                "columns (sensor.channels, sensor.min/max_elevation_deg, sensor.columns)");
}

std::vector<VelodynePacket> vlp16Packets(const LabeledCloud& scan, const LidarConfig& lidar, double stamp) {
  const auto g = grid(scan, lidar);
  const std::size_t per_packet = 2 * kBlocks, packets = g.size() / per_packet;
  const double start = stamp - kRevolution / 2;
  std::vector<VelodynePacket> out(packets);
  for (std::size_t k = 0; k < packets; ++k) {
    VelodynePacket& packet = out[k];
    const double time = start + kRevolution * static_cast<double>(k) / static_cast<double>(packets);
    packet.time_ns = static_cast<std::int64_t>(std::llround(time * 1e9));
    std::uint8_t* b = packet.bytes.data();
    for (int block = 0; block < kBlocks; ++block, b += 100) {
      const std::size_t column = k * per_packet + 2 * static_cast<std::size_t>(block);
      b[0] = 0xff;
      b[1] = 0xee;
      put16(b + 2, static_cast<std::uint32_t>(std::lround(column * lidar.azimuthStepDeg() * 100.0)) % 36000);
      for (int firing = 0; firing < 2; ++firing)
        for (int laser = 0; laser < kLasers; ++laser) {
          const Return& r = g[column + static_cast<std::size_t>(firing)][laser];
          std::uint8_t* ret = b + 4 + (firing * kLasers + laser) * 3;
          put16(ret, r.range);
          ret[2] = r.intensity;
        }
    }
    // Microseconds past the hour, the return mode (strongest) and the product id (VLP-16).
    const auto since_hour = static_cast<std::uint64_t>(std::llround(time * 1e6)) % 3'600'000'000ull;
    put16(packet.bytes.data() + 1200, static_cast<std::uint32_t>(since_hour & 0xffff));
    put16(packet.bytes.data() + 1202, static_cast<std::uint32_t>(since_hour >> 16));
    packet.bytes[1204] = 0x37;
    packet.bytes[1205] = 0x22;
  }
  return out;
}

}  // namespace hazmap::sim
