#pragma once
// Hesai packet decoding: Pandar40P, Pandar64, PandarQT64, PandarQT128, PandarXT16, PandarXT32 and
// PandarXT32M data packets (UDP port 2368; in bags pandar_msgs/msg/PandarScan) in single, dual
// and last+strongest return modes. The model comes from the packet (its start-of-packet bytes
// and the header's laser and block counts); the return mode and distance unit from the packet
// too. Each model's angle-correction file (the CSV the sensor provides: `id,elevation,azimuth`
// in degrees per channel) may be given; a built-in default is used otherwise. Points, range
// filter, dual-return duplicate filtering and the scan cut follow the nebula driver so that
// hazmap's clouds are nebula's (docs/formats.md, "Hesai").
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hazmap/sources/packet_decoder.hpp"

namespace hazmap {

enum class HesaiModel { Pandar40P, Pandar64, PandarQT64, PandarQT128, PandarXT16, PandarXT32, PandarXT32M };

/// "Pandar40P", "Pandar64", "PandarQT64", "PandarQT128", "PandarXT16", "PandarXT32", "PandarXT32M".
const char* hesaiModelName(HesaiModel model);
/// The model named `name` (as above, case-insensitive, "Pandar" optional: "XT32", "qt128"); nullopt otherwise.
std::optional<HesaiModel> hesaiModelFromName(const std::string& name);
/// The model whose data packet this payload is (from its layout), nullopt if none.
std::optional<HesaiModel> hesaiModelOfPacket(std::span<const std::uint8_t> payload);
int hesaiChannelCount(HesaiModel model);

/// Per channel (the packet's order): elevation and azimuth offset in degrees. A point's azimuth
/// is its block's azimuth plus the channel's offset.
struct HesaiCalibration {
  std::vector<double> elevation_deg, azimuth_deg;
  std::string source;  ///< "built-in" or the CSV's path
};

/// The model's built-in angles: the manufacturer's default angle-correction file for the model
/// (as nebula ships them), or the manual's nominal angles (PandarXT16).
HesaiCalibration hesaiDefaultCalibration(HesaiModel model);
/// Parses an angle-correction CSV (`id,elevation,azimuth` rows after one header line; ids 1…N,
/// N = the model's channels). A malformed file throws hazmap::Error naming `where` and the line.
HesaiCalibration parseHesaiCalibration(const std::string& text, HesaiModel model, const std::string& where);
HesaiCalibration loadHesaiCalibration(const std::filesystem::path& path, HesaiModel model);

struct HesaiOptions {
  /// Expected model; nullopt = taken from the first data packet. Packets of another model are
  /// skipped and counted (DecoderQuirks) either way.
  std::optional<HesaiModel> model;
  std::filesystem::path calibration_file;  ///< angle-correction CSV; empty = built-in
  /// Range kept (m, inclusive), further limited to the model's own range (nebula's limits:
  /// Pandar40P/64 0.3–200, QT64 0.1–60, QT128 0.05–50, XT16/XT32 0.05–120, XT32M 0.5–300).
  double min_range = 0.3, max_range = 300.0;
  double cut_angle = 0.0;  ///< azimuth (degrees, 0–360) where one scan ends and the next begins
  double fov_min = 0.0, fov_max = 360.0;  ///< azimuths kept (degrees), wrapping when min > max
  /// Multi-return modes: a return other than the group's last is dropped when another return of
  /// the same firing lies within this distance (m), as nebula's dual_return_distance_threshold.
  double dual_return_distance_threshold = 0.1;
};

/// DecodedScan: x forward (azimuth 0), y left, z up (ROS convention; nebula's Hesai clouds have x
/// right, y forward); intensity = the return's reflectivity (0–255); timestamps = packet time +
/// the block's firing offset from the manual (+ the channel's for the XT models); ring = 0 for
/// the lowest elevation; return_type = 0 in single return modes, else 1 + the return's block
/// within its firing (last+strongest: 1 last, 2 strongest). 512-byte GPS packets are ignored;
/// other odd input is skipped and counted in quirks() (docs/formats.md, "Tolerant decoding").
std::unique_ptr<PacketDecoder> makeHesaiDecoder(const HesaiOptions& options = {});

inline constexpr std::uint16_t kHesaiDataPort = 2368;

}  // namespace hazmap
