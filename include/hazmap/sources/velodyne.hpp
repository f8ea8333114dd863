#pragma once
// Velodyne packet decoding: VLP-16, VLP-32C, HDL-32E and VLS-128 data packets (1206-byte UDP
// payloads, single strongest / last or dual return) into scans. The model and return mode come
// from the two factory bytes at the end of each data packet; each model's factory calibration
// (elevation and azimuth angles from the manufacturer's manual) is built in, and a calibration
// YAML in the ROS velodyne_pointcloud / nebula format may replace it. Geometry, azimuth
// interpolation and scan cutting follow the nebula driver (Autoware), so that hazmap's clouds
// are the driver's clouds point for point (docs/formats.md, "Velodyne").
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "hazmap/sources/packet_decoder.hpp"

namespace hazmap {

enum class VelodyneModel { VLP16, VLP32C, HDL32E, VLS128 };

/// "VLP-16", "VLP-32C", "HDL-32E", "VLS-128".
const char* velodyneModelName(VelodyneModel model);
/// The model whose product id (factory byte 1205) this is: 0x22 VLP-16 (and Puck LITE),
/// 0x28 VLP-32C, 0x21 HDL-32E (also sent by early VLP-16 firmware: the decoder tells them apart
/// by the packet period), 0xA1 VLS-128 (Alpha Prime). nullopt for any other byte.
std::optional<VelodyneModel> velodyneModelFromProductId(std::uint8_t product_id);
/// Number of lasers of the model (16, 32, 32, 128).
int velodyneLaserCount(VelodyneModel model);

/// Per-point return type of a Velodyne scan (DecodedScan::return_type).
enum class VelodyneReturn : std::uint8_t {
  Strongest = 1,       ///< single return mode 0x37
  Last = 2,            ///< single return mode 0x38
  DualBoth = 3,        ///< dual mode: the last and the strongest echo are one and the same
  DualLast = 4,        ///< dual mode: the last echo (the strongest is another point)
  DualStrongest = 5,   ///< dual mode: the strongest echo, not the last
  DualSecond = 6,      ///< dual mode: the second strongest (the strongest is also the last)
};

/// One laser's correction, in the ROS calibration file's conventions: angles in radians,
/// distances in metres. A point's azimuth is the rotor's azimuth minus rot_correction.
struct VelodyneLaser {
  double rot_correction = 0.0;           ///< azimuth offset (rad), subtracted
  double vert_correction = 0.0;          ///< elevation (rad)
  double dist_correction = 0.0;          ///< added to every non-zero range (m)
  double dist_correction_x = 0.0, dist_correction_y = 0.0;  ///< HDL two-point corrections (m)
  bool two_pt_correction_available = false;
  double vert_offset_correction = 0.0;   ///< vertical offset of the laser's origin (m)
  double horiz_offset_correction = 0.0;  ///< horizontal offset of the laser's origin (m)
  double min_intensity = 0.0, max_intensity = 255.0;
  double focal_distance = 0.0, focal_slope = 0.0;
  std::uint16_t ring = 0;                ///< 0 = lowest elevation (computed, not read)
};

struct VelodyneCalibration {
  VelodyneModel model = VelodyneModel::VLP16;
  double distance_resolution = 0.002;  ///< metres per range unit
  std::vector<VelodyneLaser> lasers;   ///< indexed by laser id (the packet's channel order)
  std::string source;                  ///< "factory" or the YAML's path
};

/// The built-in calibration of the model, from the manufacturer's manual.
VelodyneCalibration velodyneFactoryCalibration(VelodyneModel model);
/// A calibration YAML (`num_lasers`, `distance_resolution`, `lasers: [{laser_id,
/// rot_correction, vert_correction, dist_correction, ...}]`) for `model`. Throws hazmap::Error
/// naming the file on a missing file, bad YAML, a missing field, a laser id out of range or a
/// laser count that is not the model's.
VelodyneCalibration loadVelodyneCalibration(const std::filesystem::path& path, VelodyneModel model);

struct VelodyneOptions {
  /// Expected model; nullopt = taken from the first data packet's product id. Packets of
  /// another product id are skipped and counted (DecoderQuirks) either way.
  std::optional<VelodyneModel> model;
  /// Calibration YAML; empty = the model's factory calibration.
  std::filesystem::path calibration_file;
  double min_range = 0.3;      ///< m; points at or below are dropped
  double max_range = 300.0;    ///< m; points at or beyond are dropped
  /// Azimuth (degrees, sensor frame, 0–360) where one scan ends and the next begins.
  double cut_angle = 0.0;
  /// Field of view kept (degrees): [fov_min, fov_max], wrapping through 0 when fov_min >
  /// fov_max (e.g. 270 → 90 keeps the front half). Like the driver's cloud_min/max_angle.
  double fov_min = 0.0, fov_max = 360.0;
  /// false (default): a point's azimuth is interpolated between blocks as the drivers do, so
  /// that clouds equal nebula's. true: from the laser's firing time (the manuals' timing
  /// tables) and the rotor speed measured over the packet, which removes the drivers' lags of
  /// up to 0.16° (docs/formats.md); the clouds then differ from the driver's by that much.
  bool exact_azimuth = false;
};

/// A decoder of one sensor's data packets (512-byte position packets are ignored).
/// DecodedScan: x forward, y left, z up (ROS convention); cloud.intensity = calibrated
/// intensity 0–255; cloud.timestamps = absolute firing time (packet time + the firing's offset
/// from the manual's timing table); ring = 0 for the lowest laser; return_type = VelodyneReturn.
/// Odd input is tolerated and counted in quirks(), never thrown: packets with unsupported
/// factory bytes or of another model and datagrams of other sizes are skipped, a block azimuth
/// of 36000 is wrapped to 0, blocks with no bank id, an azimuth above 36000 or out of azimuth
/// order are skipped alone (docs/formats.md, "Tolerant decoding").
std::unique_ptr<PacketDecoder> makeVelodyneDecoder(const VelodyneOptions& options = {});

/// Size of a Velodyne data packet and of a position packet (UDP payload bytes).
inline constexpr std::size_t kVelodyneDataPacketSize = 1206;
inline constexpr std::size_t kVelodynePositionPacketSize = 512;

}  // namespace hazmap
