#pragma once
// Where everything is in a Hesai data packet, per model (from the models' user manuals, "Data
// Packet Format"; internal to the Hesai decoder). Two generations:
//   Pandar40P: no header; 10 blocks of {0xFFEE, azimuth u16 (0.01°), 40 × {distance u16,
//     reflectivity u8}}; a 22-byte tail (…, motor speed, timestamp µs, return mode, factory
//     byte, date); distance unit 4 mm.
//   Pandar64: an 8-byte header (0xEEFF, lasers, blocks, -, distance unit mm, -, -), 6 blocks of
//     {azimuth, 64 × 3 bytes}, the same 22-byte tail.
//   QT and XT: a 12-byte header (0xEEFF, protocol version, -, lasers, blocks, -, distance unit,
//     returns, flags), blocks of {azimuth, N × {distance u16, reflectivity u8, reserved u8}},
//     then (QT128) a body CRC and a functional-safety part, and a tail with the return mode.
// Multi-byte fields are little-endian; optional trailers (UDP sequence, cyber security) follow.
#include <cstddef>
#include <cstdint>

#include "hazmap/sources/hesai.hpp"

namespace hazmap::hesai_detail {

struct HesaiLayout {
  HesaiModel model;
  std::size_t size;            ///< bytes up to the end of the tail (optional trailers may follow)
  std::size_t header;          ///< bytes before the first block
  int blocks, channels;
  int unit;                    ///< bytes per return (3 or 4)
  int azimuth_at;              ///< the azimuth's offset in a block (2 after the 40P's 0xFFEE)
  std::size_t block_bytes;
  std::size_t return_mode_at;  ///< offset of the tail's return-mode byte
  int distance_unit_at;        ///< header byte holding the distance unit (mm); -1: always 4 mm
  float min_range, max_range;  ///< the model's range (m), as nebula limits it
  /// Firing time of block b (ns, relative to the packet's timestamp), n returns per firing.
  double blockOffsetNs(int b, int n) const;
  /// Firing time of channel c within its block (ns); 0 where the manual's table is not modelled.
  double channelOffsetNs(int c) const;
};

const HesaiLayout& hesaiLayout(HesaiModel model);

inline std::uint16_t u16(const std::uint8_t* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }

/// Returns per firing of a return-mode byte (0x33–0x38 single, 0x39–0x3c and 0x3e dual, 0x3d
/// triple), 0 for an unknown byte.
int returnsOfMode(std::uint8_t mode);

}  // namespace hazmap::hesai_detail
