#pragma once
// The byte layout of Ouster lidar packets per profile (from the sensor's firmware user manual,
// "Lidar Data Packet Format"), and the XYZ look-up table. Internal to the Ouster decoder.
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "hazmap/sources/ouster.hpp"

namespace hazmap::ouster_detail {

template <typename T>
T load(const std::uint8_t* p) {  // the packets are little-endian, like the machines we run on
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// Where everything is in one lidar packet.
///   LEGACY: no packet header/footer; each column = 16-byte header (timestamp u64, measurement
///     id u16, frame id u16, encoder count u32), pixels of 12 bytes, 4-byte status footer.
///   Others: 32-byte packet header (packet type u16, frame id u16, init id u24, serial u40, ...),
///     columns of a 12-byte header (timestamp u64, measurement id u16, status u16) and pixels,
///     then a 32-byte packet footer.
struct PacketLayout {
  explicit PacketLayout(const OusterMetadata& m);

  OusterProfile profile;
  std::size_t pixels = 0, columns = 0;
  std::size_t packet_header = 0, column_header = 0, pixel_size = 0, column_footer = 0,
              packet_footer = 0, column_size = 0, packet_size = 0;
  bool dual = false;

  const std::uint8_t* column(const std::uint8_t* packet, std::size_t i) const {
    return packet + packet_header + i * column_size;
  }
  std::uint16_t frameId(const std::uint8_t* packet) const {
    return profile == OusterProfile::Legacy ? load<std::uint16_t>(packet + 10) : load<std::uint16_t>(packet + 2);
  }
  std::uint16_t packetType(const std::uint8_t* packet) const {
    return profile == OusterProfile::Legacy ? 1 : load<std::uint16_t>(packet);
  }
  std::uint32_t initId(const std::uint8_t* packet) const {
    return profile == OusterProfile::Legacy ? 0 : load<std::uint32_t>(packet + 4) & 0xffffffu;
  }
  std::uint64_t serial(const std::uint8_t* packet) const {
    return profile == OusterProfile::Legacy ? 0 : load<std::uint64_t>(packet + 7) & 0xffffffffffull;
  }
  static std::uint64_t timestamp(const std::uint8_t* col) { return load<std::uint64_t>(col); }
  static std::uint16_t measurementId(const std::uint8_t* col) { return load<std::uint16_t>(col + 8); }
  bool valid(const std::uint8_t* col) const {
    const std::uint32_t status = profile == OusterProfile::Legacy
        ? load<std::uint32_t>(col + column_header + pixels * pixel_size)
        : load<std::uint16_t>(col + 10);
    return (status & 1u) != 0;
  }

  /// Range (mm) and intensity of every pixel of a column; the second return too for dual profiles.
  void decodeColumn(const std::uint8_t* col, bool reflectivity, std::uint32_t* range,
                    std::uint16_t* intensity, std::uint32_t* range2, std::uint16_t* intensity2) const;
};

/// ouster-sdk's XYZ look-up table: point = range_mm · direction + offset (metres, sensor frame),
/// for a non-zero range; index (column · pixels + row) · 3.
struct XyzLut {
  std::vector<float> direction, offset;
};
XyzLut makeXyzLut(const OusterMetadata& m);

}  // namespace hazmap::ouster_detail
