#pragma once
// Ouster OS sensors: the sensor's metadata JSON (both the flat layout of firmware ≤ 2.3 and the
// nested layout of later firmware) and a packet decoder for the LEGACY,
// RNG19_RFL8_SIG16_NIR16 (single return), RNG19_RFL8_SIG16_NIR16_DUAL and RNG15_RFL8_NIR8
// (low bandwidth) lidar packet profiles. Points are computed the way ouster-sdk's XYZ look-up
// table does (beam intrinsics, encoder angle of the column, beam origin offset,
// lidar_to_sensor_transform), so they are in the sensor frame, in metres.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "hazmap/io/imu.hpp"
#include "hazmap/sources/packet_decoder.hpp"

namespace hazmap {

enum class OusterProfile { Legacy, Rng19Rfl8Sig16Nir16, Rng19Rfl8Sig16Nir16Dual, Rng15Rfl8Nir8 };

/// The profile's name as the sensor spells it ("LEGACY", "RNG19_RFL8_SIG16_NIR16", ...).
std::string toString(OusterProfile profile);

struct OusterMetadata {
  std::string prod_line;   ///< e.g. "OS-1-128"; empty when the metadata does not say
  std::string firmware;    ///< build_rev, e.g. "v2.3.0"
  std::string serial;      ///< prod_sn
  std::uint64_t initialization_id = 0;  ///< 0 when absent (packets are then not checked against it)
  std::string lidar_mode;  ///< e.g. "1024x10"
  double scan_rate_hz = 0.0;            ///< from lidar_mode (10, 20, 5)
  std::uint32_t columns_per_frame = 0;  ///< w
  std::uint32_t pixels_per_column = 0;  ///< h (beams)
  std::uint32_t columns_per_packet = 16;
  std::uint32_t column_window_first = 0, column_window_last = 0;  ///< inclusive, may wrap
  OusterProfile profile = OusterProfile::Legacy;
  std::vector<int> pixel_shift_by_row;  ///< for destaggering images; not needed for xyz
  std::vector<double> beam_altitude_deg, beam_azimuth_deg;  ///< one per row
  double lidar_origin_to_beam_origin_mm = 0.0;
  Eigen::Matrix4d beam_to_lidar = Eigen::Matrix4d::Identity();    ///< translation in mm
  Eigen::Matrix4d lidar_to_sensor = Eigen::Matrix4d::Identity();  ///< translation in mm
  Eigen::Matrix4d imu_to_sensor = Eigen::Matrix4d::Identity();    ///< translation in mm
  std::uint16_t udp_port_lidar = 0, udp_port_imu = 0;  ///< 0 when absent
  bool nested_layout = false;  ///< which JSON layout it was read from

  /// Columns inside column_window (the sensor sends only these; a full scan has this many).
  std::uint32_t columnsInWindow() const;
  /// Bytes of one lidar packet of this profile and geometry.
  std::size_t lidarPacketSize() const;
  std::string describe() const;  ///< e.g. "Ouster OS-1-128 1024x10 RNG15_RFL8_NIR8"
};

/// Parses the metadata JSON. Missing optional fields get the sensor's documented defaults (as
/// ouster-sdk does: beam origin by product line, lidar_to_sensor of an OS-1); missing or
/// inconsistent required fields (beam angles, lidar mode or columns_per_frame, an unknown
/// profile) throw hazmap::Error naming `where`.
OusterMetadata parseOusterMetadata(std::string_view json, const std::string& where);
/// Reads and parses a metadata file; errors name the file.
OusterMetadata readOusterMetadata(const std::filesystem::path& path);
/// The metadata file recorded with a capture, as ouster-sdk pairs them: the .json in the
/// capture's folder whose name (without extension) is the longest prefix of the capture's name
/// ("OS-1-128_v2.3.0_1024x10.json" for "OS-1-128_v2.3.0_1024x10_lb_n3.pcap"); nullopt if none.
std::optional<std::filesystem::path> findOusterMetadata(const std::filesystem::path& capture);

/// Bytes of an Ouster IMU packet (LEGACY IMU profile, every firmware so far).
inline constexpr std::size_t kOusterImuPacketSize = 48;

/// One decoded IMU packet: the sample in the sensor frame (rotated by imu_to_sensor; rad/s, m/s²)
/// and the gyro's timestamp on the sensor's clock (ns). `sample.time` is left 0: the decoder
/// puts it on the scans' clock.
struct OusterImuPacket {
  ImuSample sample;
  std::uint64_t gyro_time_ns = 0;
};
/// nullopt for a payload of another size or with non-finite values.
std::optional<OusterImuPacket> decodeOusterImuPacket(std::span<const std::uint8_t> payload,
                                                     const OusterMetadata& metadata);

struct OusterDecoderOptions {
  /// Per-point intensity: the signal photon count (default; profiles without it — the
  /// low-bandwidth RNG15 — fall back to reflectivity) or the calibrated reflectivity.
  enum class Intensity { Signal, Reflectivity } intensity = Intensity::Signal;
  /// A scan missing columns of its column window (the capture started or ended mid-rotation,
  /// packets were lost) is dropped by default and counted in stats().
  bool keep_incomplete_scans = false;
  /// Per-point time. Sensor: the column timestamps (s) as they are. Capture: the column
  /// timestamps shifted onto the packets' receive time (for a sensor clocked from its internal
  /// oscillator, which counts from boot). Auto: Sensor if the timestamps are after 2001 (PTP
  /// or GPS synchronised), else Capture.
  enum class Clock { Auto, Sensor, Capture } clock = Clock::Auto;
  /// Dual-return profiles: also emit the second return's points (return_type 1).
  bool second_return = true;
};

struct OusterDecoderStats {
  std::uint64_t lidar_packets = 0;       ///< packets of the lidar packet size decoded
  std::uint64_t other_packets = 0;       ///< other sizes (IMU packets and anything else) ignored
  std::uint64_t imu_packets = 0;         ///< IMU packets decoded (takeImu)
  std::uint64_t foreign_packets = 0;     ///< lidar-sized packets of another sensor (init id / serial)
  std::uint64_t late_packets = 0;        ///< packets of the previous frame after it was emitted
  std::uint64_t invalid_columns = 0;     ///< columns whose status says they hold no data
  std::uint64_t scans_emitted = 0;
  std::uint64_t incomplete_scans_dropped = 0;
  std::uint64_t last_other_size = 0;     ///< size of the last ignored packet (for messages)
};

class OusterDecoder : public PacketDecoder {
 public:
  OusterDecoder(const OusterMetadata& metadata, const OusterDecoderOptions& options = {});
  ~OusterDecoder() override;
  void addPacket(std::span<const std::uint8_t> payload, double packet_time,
                 const std::string& where) override;
  std::optional<DecodedScan> takeScan() override;
  std::optional<DecodedScan> flush() override;
  std::vector<ImuSample> takeImu() override;
  std::string describe() const override;
  const OusterDecoderStats& stats() const;
  const OusterMetadata& metadata() const;
  /// One line each, naming `where`, for what was dropped so far (incomplete scans, late or
  /// foreign packets) and for input that does not fit the metadata (no packet of its lidar
  /// packet size). Empty when everything decoded.
  std::vector<std::string> notices(const std::string& where) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The decoder for this metadata.
std::unique_ptr<OusterDecoder> makeOusterDecoder(const OusterMetadata& metadata,
                                                 const OusterDecoderOptions& options = {});

}  // namespace hazmap
