// Velodyne data packets → scans. Packet layout (all models): 12 blocks of 100 bytes (uint16
// bank id, uint16 azimuth in 0.01°, 32 × {uint16 range, uint8 intensity}), a uint32 timestamp
// (µs past the hour), then the two factory bytes: return mode (0x37 strongest, 0x38 last,
// 0x39 dual) and product id. Azimuth interpolation, range and field-of-view filters and scan
// cutting follow the nebula driver so that the clouds are the driver's (docs/formats.md).
#include "sources/velodyne_decoder.hpp"

#include <fmt/format.h>

#include <cstring>

#include "hazmap/core/error.hpp"

namespace hazmap {
namespace velodyne_detail {

const AzimuthTable& azimuthTable() {
  static const AzimuthTable table;
  return table;
}

std::vector<LaserTerms> laserTerms(const VelodyneCalibration& cal) {
  std::vector<LaserTerms> out;
  for (const VelodyneLaser& l : cal.lasers) {
    const float fd = static_cast<float>(l.focal_distance);
    const float fo = 256.0f * (1 - fd / 13100) * (1 - fd / 13100);
    out.push_back({std::cos(static_cast<float>(l.vert_correction)),
                   std::sin(static_cast<float>(l.vert_correction)),
                   static_cast<double>(static_cast<float>(l.rot_correction)) * 180.0 / M_PI * 100,
                   static_cast<float>(l.dist_correction), static_cast<float>(l.dist_correction_x),
                   static_cast<float>(l.dist_correction_y),
                   static_cast<float>(l.vert_offset_correction),
                   static_cast<float>(l.horiz_offset_correction),
                   static_cast<float>(l.min_intensity), static_cast<float>(l.max_intensity), fo,
                   static_cast<float>(l.focal_slope), l.two_pt_correction_available, l.ring});
  }
  return out;
}

BlockAzimuths blockAzimuths(const std::uint8_t* packet, int used_blocks, bool dual,
                            int last_block_without_diff) {
  BlockAzimuths out{};
  const int step = dual ? 2 : 1;
  std::uint16_t next = 0;
  float last_diff = 0;
  for (int b = 0; b < used_blocks; ++b) {
    const std::uint16_t az = b == 0 ? u16(packet + 2) : next;
    out.azimuth[b] = az;
    if (b < kBlocks - step) {
      next = u16(packet + (b + step) * kBlockBytes + 2);
      out.diff[b] = static_cast<float>((kCentiDegrees + next - az) % kCentiDegrees);
      last_diff = out.diff[b];
    } else {
      out.diff[b] = b == last_block_without_diff ? 0.0f : last_diff;
    }
  }
  return out;
}

VelodyneDecoder::VelodyneDecoder(const VelodyneOptions& options) : options_(options) {
  if (!(options.min_range >= 0 && options.max_range > options.min_range))
    fail("Velodyne decoder", "min_range/max_range must satisfy 0 <= min < max");
  if (!(options.cut_angle >= 0 && options.cut_angle <= 360) || !(options.fov_min >= 0) ||
      !(options.fov_max <= 360) || !(options.fov_min <= 360) || !(options.fov_max >= 0))
    fail("Velodyne decoder", "cut_angle and fov_min/fov_max must be in [0, 360] degrees");
  cut_cd_ = static_cast<std::uint32_t>(std::lround(options.cut_angle * 100)) % kCentiDegrees;
  fov_min_cd_ = static_cast<int>(std::lround(options.fov_min * 100));
  fov_max_cd_ = static_cast<int>(std::lround(options.fov_max * 100));
}

std::optional<DecodedScan> VelodyneDecoder::takeScan() {
  if (ready_.empty()) return std::nullopt;
  DecodedScan s = std::move(ready_.front());
  ready_.pop_front();
  return s;
}

std::optional<DecodedScan> VelodyneDecoder::flush() {
  if (!held_.empty()) {  // a lone 0x21 packet: take the product id at its word
    setUp(VelodyneModel::HDL32E);
    const std::vector<std::uint8_t> held = std::move(held_);
    held_.clear();
    decodePacket(held.data(), held_time_, held_where_);
  }
  if (auto scan = takeScan()) return scan;
  if (scan_.cloud.empty()) return std::nullopt;
  DecodedScan s = std::move(scan_);
  s.stamp = s.cloud.timestamps.front();
  scan_ = DecodedScan{};
  scan_.cloud.enableIntensity();
  scan_.cloud.enableTimestamps();
  azimuth_cd_.clear();
  packets_in_scan_ = 0;
  return s;
}

std::string VelodyneDecoder::describe() const {
  if (!model_) return "Velodyne (no data packet yet)";
  const char* mode = last_mode_ == kModeDual ? "dual return"
                     : last_mode_ == kModeLast ? "last return" : "strongest return";
  return fmt::format("Velodyne {} ({}), {} calibration", velodyneModelName(*model_), mode,
                     calibration_source_);
}

void VelodyneDecoder::setUp(VelodyneModel model) {
  const VelodyneCalibration cal = options_.calibration_file.empty()
                                      ? velodyneFactoryCalibration(model)
                                      : loadVelodyneCalibration(options_.calibration_file, model);
  model_ = model;
  calibration_source_ = cal.source;
  distance_resolution_ = static_cast<float>(cal.distance_resolution);
  lasers_ = laserTerms(cal);
  scan_.cloud.enableIntensity();
  scan_.cloud.enableTimestamps();
}

namespace {

/// Early VLP-16 firmware reports the HDL-32E's product id 0x21. The packet period tells them
/// apart whatever the rotation speed: a VLP-16 packet holds 24 firing sequences of 55.296 µs
/// (12 in dual return), an HDL-32E packet 12 of 46.08 µs (6).
VelodyneModel disambiguate0x21(const std::uint8_t* first, const std::uint8_t* second) {
  const auto stamp = [](const std::uint8_t* p) {
    return static_cast<std::int64_t>(p[1200] | (p[1201] << 8) | (p[1202] << 16)) |
           (static_cast<std::int64_t>(p[1203]) << 24);
  };
  const std::int64_t hour_us = 3600LL * 1000000;
  const double dt = static_cast<double>(((stamp(second) - stamp(first)) % hour_us + hour_us) % hour_us);
  const bool dual = second[1204] == kModeDual;
  const double vlp16 = (dual ? 12 : 24) * 55.296, hdl32 = (dual ? 6 : 12) * 46.08;
  return std::abs(dt - vlp16) < std::abs(dt - hdl32) ? VelodyneModel::VLP16 : VelodyneModel::HDL32E;
}

bool productFits(VelodyneModel model, std::uint8_t product) {
  const auto said = velodyneModelFromProductId(product);
  return said == model || (model == VelodyneModel::VLP16 && product == 0x21);
}

}  // namespace

void VelodyneDecoder::addPacket(std::span<const std::uint8_t> payload, double packet_time,
                                const std::string& where) {
  if (payload.size() == kVelodynePositionPacketSize) return;
  if (payload.size() != kVelodyneDataPacketSize) {
    quirks_.note("Velodyne datagrams neither a data (1206 bytes) nor a position packet (truncated?) skipped", where);
    return;
  }
  const std::uint8_t* p = payload.data();
  const std::uint8_t mode = p[1204], product = p[1205];
  const auto model = velodyneModelFromProductId(product);
  const bool mode_ok = mode == kModeStrongest || mode == kModeLast || mode == kModeDual;
  if (!model || !mode_ok) {
    quirks_.note(fmt::format("Velodyne packets with unsupported factory bytes (e.g. 0x{:02x} 0x{:02x}: return "
                             "mode, product id) skipped", mode, product), where);
    return;
  }
  const VelodyneModel expected = model_ ? *model_ : options_.model ? *options_.model : *model;
  if (!productFits(expected, product)) {
    quirks_.note(fmt::format("Velodyne packets of another model ({}, expected {}) skipped",
                             velodyneModelName(*model), velodyneModelName(expected)), where);
    return;
  }
  if (!model_ && !options_.model && product == 0x21) {
    if (held_.empty()) {  // decide with the next packet
      held_.assign(p, p + kVelodyneDataPacketSize);
      held_time_ = packet_time;
      held_where_ = where;
      return;
    }
    setUp(disambiguate0x21(held_.data(), p));
  }
  if (!model_) setUp(expected);
  if (!held_.empty()) {
    const std::vector<std::uint8_t> held = std::move(held_);
    held_.clear();
    decodePacket(held.data(), held_time_, held_where_);
  }
  decodePacket(p, packet_time, where);
}

void VelodyneDecoder::decodePacket(const std::uint8_t* raw, double packet_time,
                                   const std::string& where) {
  std::memcpy(packet_.data(), raw, kVelodyneDataPacketSize);
  const std::uint8_t* p = packet_.data();
  const std::uint8_t mode = p[1204];
  if (!repairBlocks(mode, where)) return;
  ++quirks_.decoded_packets;
  last_mode_ = mode;
  const Cut cut = findCut(p);
  if (cut == Cut::BeforePacket) cutScan(false);
  if (options_.exact_azimuth) fitRotor(p, mode);
  switch (*model_) {
    case VelodyneModel::VLP16: decode16(p, packet_time, mode); break;
    case VelodyneModel::VLP32C:
    case VelodyneModel::HDL32E: decode32(p, packet_time, mode); break;
    case VelodyneModel::VLS128: decode128(p, packet_time, mode); break;
  }
  if (cut == Cut::WithinPacket) cutScan(true);
}

/// Like the drivers: the scan is complete when a packet's azimuth passes the cut angle, within
/// the packet or since the previous packet (a jump, e.g. out of a restricted field of view, or
/// a packet that starts right past the cut).
VelodyneDecoder::Cut VelodyneDecoder::findCut(const std::uint8_t* packet) {
  ++packets_in_scan_;
  const std::uint32_t first = u16(packet + 2), last = u16(packet + (kBlocks - 1) * kBlockBytes + 2);
  const std::uint32_t first_phased = (kCentiDegrees + first - cut_cd_) % kCentiDegrees;
  const std::uint32_t last_phased = (kCentiDegrees + last - cut_cd_) % kCentiDegrees;
  const std::uint32_t prev_first_phased = prev_first_phased_;
  prev_first_phased_ = first_phased;
  if (packets_in_scan_ <= 1) return Cut::None;
  if (last_phased < first_phased) return Cut::WithinPacket;
  if (first_phased < prev_first_phased) return Cut::BeforePacket;
  return Cut::None;
}

/// Emits the scan. After a packet that crossed the cut angle, that packet's trailing points
/// already past the cut (within 2°, as nebula does) open the next scan.
void VelodyneDecoder::cutScan(bool move_tail) {
  std::size_t keep = scan_.cloud.size();
  while (move_tail && keep > 0 &&
         (kCentiDegrees + azimuth_cd_[keep - 1] - cut_cd_) % kCentiDegrees < 200)
    --keep;
  DecodedScan next;
  next.cloud = scan_.cloud.slice(keep, scan_.cloud.size());
  next.cloud.enableIntensity();
  next.cloud.enableTimestamps();
  next.ring.assign(scan_.ring.begin() + keep, scan_.ring.end());
  next.return_type.assign(scan_.return_type.begin() + keep, scan_.return_type.end());
  std::vector<std::uint16_t> next_az(azimuth_cd_.begin() + keep, azimuth_cd_.end());
  scan_.cloud.resize(keep);
  scan_.ring.resize(keep);
  scan_.return_type.resize(keep);
  if (keep > 0) {
    scan_.stamp = scan_.cloud.timestamps.front();
    ready_.push_back(std::move(scan_));
  }
  scan_ = std::move(next);
  azimuth_cd_ = std::move(next_az);
  packets_in_scan_ = move_tail ? 0 : 1;
}

}  // namespace velodyne_detail

std::unique_ptr<PacketDecoder> makeVelodyneDecoder(const VelodyneOptions& options) {
  return std::make_unique<velodyne_detail::VelodyneDecoder>(options);
}

}  // namespace hazmap
