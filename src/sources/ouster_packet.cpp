#include "sources/ouster_packet.hpp"

#include <cmath>
#include <numbers>

namespace hazmap::ouster_detail {

PacketLayout::PacketLayout(const OusterMetadata& m)
    : profile(m.profile), pixels(m.pixels_per_column), columns(m.columns_per_packet) {
  const bool legacy = profile == OusterProfile::Legacy;
  packet_header = legacy ? 0 : 32;
  column_header = legacy ? 16 : 12;
  column_footer = legacy ? 4 : 0;
  packet_footer = legacy ? 0 : 32;
  switch (profile) {
    case OusterProfile::Legacy:
    case OusterProfile::Rng19Rfl8Sig16Nir16: pixel_size = 12; break;
    case OusterProfile::Rng19Rfl8Sig16Nir16Dual: pixel_size = 16; break;
    case OusterProfile::Rng15Rfl8Nir8: pixel_size = 4; break;
  }
  dual = profile == OusterProfile::Rng19Rfl8Sig16Nir16Dual;
  column_size = column_header + pixels * pixel_size + column_footer;
  packet_size = packet_header + columns * column_size + packet_footer;
}

void PacketLayout::decodeColumn(const std::uint8_t* col, bool reflectivity, std::uint32_t* range,
                                std::uint16_t* intensity, std::uint32_t* range2,
                                std::uint16_t* intensity2) const {
  const std::uint8_t* px = col + column_header;
  switch (profile) {
    case OusterProfile::Legacy:  // range u32 (20 bits), reflectivity u16, signal u16, near-IR u16
      for (std::size_t r = 0; r < pixels; ++r, px += 12) {
        range[r] = load<std::uint32_t>(px) & 0xfffffu;
        intensity[r] = load<std::uint16_t>(px + (reflectivity ? 4 : 6));
      }
      break;
    case OusterProfile::Rng19Rfl8Sig16Nir16:  // range u32 (19 bits), reflectivity u8 @4, signal u16 @6
      for (std::size_t r = 0; r < pixels; ++r, px += 12) {
        range[r] = load<std::uint32_t>(px) & 0x7ffffu;
        intensity[r] = reflectivity ? px[4] : load<std::uint16_t>(px + 6);
      }
      break;
    case OusterProfile::Rng19Rfl8Sig16Nir16Dual:
      // range u32 (19 bits) with reflectivity u8 @3, range2 @4 with reflectivity2 @7, signal u16
      // @8, signal2 u16 @10, near-IR u16 @12
      for (std::size_t r = 0; r < pixels; ++r, px += 16) {
        range[r] = load<std::uint32_t>(px) & 0x7ffffu;
        range2[r] = load<std::uint32_t>(px + 4) & 0x7ffffu;
        intensity[r] = reflectivity ? px[3] : load<std::uint16_t>(px + 8);
        intensity2[r] = reflectivity ? px[7] : load<std::uint16_t>(px + 10);
      }
      break;
    case OusterProfile::Rng15Rfl8Nir8:  // range u16 (15 bits) in units of 8 mm, reflectivity u8, near-IR u8
      for (std::size_t r = 0; r < pixels; ++r, px += 4) {
        range[r] = std::uint32_t{load<std::uint16_t>(px) & 0x7fffu} << 3;
        intensity[r] = px[2];  // no signal field: reflectivity either way
      }
      break;
  }
}

XyzLut makeXyzLut(const OusterMetadata& m) {
  const std::size_t w = m.columns_per_frame, h = m.pixels_per_column;
  const Eigen::Matrix4d& b = m.beam_to_lidar;
  // The beam origin is off the lidar axis by b(0,3) radially and b(2,3) vertically; the range
  // is measured from the beam origin along the beam.
  const double origin_distance = b(2, 3) != 0.0 ? std::hypot(b(0, 3), b(2, 3)) : b(0, 3);
  const Eigen::Matrix3d rotation = m.lidar_to_sensor.topLeftCorner<3, 3>();
  const Eigen::Vector3d translation = m.lidar_to_sensor.topRightCorner<3, 1>();
  constexpr double kMillimetre = 0.001;
  constexpr double kDegree = std::numbers::pi / 180.0;
  XyzLut lut;
  lut.direction.resize(w * h * 3);
  lut.offset.resize(w * h * 3);
  for (std::size_t c = 0; c < w; ++c) {
    // Measurement id c is taken at encoder angle 2π·(1 − c/w): the sensor spins clockwise seen from above.
    const double encoder = 2.0 * std::numbers::pi * (1.0 - static_cast<double>(c) / static_cast<double>(w));
    for (std::size_t r = 0; r < h; ++r) {
      const double azimuth = encoder - m.beam_azimuth_deg[r] * kDegree;
      const double altitude = m.beam_altitude_deg[r] * kDegree;
      const Eigen::Vector3d dir(std::cos(azimuth) * std::cos(altitude),
                                std::sin(azimuth) * std::cos(altitude), std::sin(altitude));
      const Eigen::Vector3d off(std::cos(encoder) * b(0, 3) - dir.x() * origin_distance,
                                std::sin(encoder) * b(0, 3) - dir.y() * origin_distance,
                                -dir.z() * origin_distance + b(2, 3));
      const Eigen::Vector3d d = rotation * dir * kMillimetre;
      const Eigen::Vector3d o = (rotation * off + translation) * kMillimetre;
      for (int k = 0; k < 3; ++k) {
        lut.direction[(c * h + r) * 3 + static_cast<std::size_t>(k)] = static_cast<float>(d[k]);
        lut.offset[(c * h + r) * 3 + static_cast<std::size_t>(k)] = static_cast<float>(o[k]);
      }
    }
  }
  return lut;
}

}  // namespace hazmap::ouster_detail

namespace hazmap {

std::size_t OusterMetadata::lidarPacketSize() const { return ouster_detail::PacketLayout(*this).packet_size; }

}  // namespace hazmap
