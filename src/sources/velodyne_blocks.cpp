// The Velodyne models' block layouts: which laser each range belongs to, when it fired (the
// manuals' timing tables) and at which azimuth, then the ROS/nebula calibration geometry.
#include <cmath>
#include <cstring>

#include "sources/velodyne_decoder.hpp"

namespace hazmap::velodyne_detail {

namespace {

bool sameReturn(const std::uint8_t* a, const std::uint8_t* b) { return a[0] == b[0] && a[1] == b[1]; }

/// Fraction of the block-to-block azimuth step at which each VLS-128 firing group fires (16
/// groups of 8 lasers, one idle slot after the eighth group).
struct Vls128Phase {
  float of_group[16];
  Vls128Phase() {
    for (int g = 0; g < 16; ++g) of_group[g] = (2.665f / 53.3f) * static_cast<float>(g + g / 8);
  }
};

}  // namespace

/// Dual return packets pair blocks (2k, 2k+1): the even one holds the last echo, the odd one
/// the strongest (or, when the last is also the strongest, the second strongest).
VelodyneReturn VelodyneDecoder::returnType(std::uint8_t mode, int block, const std::uint8_t* ret,
                                           const std::uint8_t* other) const {
  if (mode == kModeStrongest) return VelodyneReturn::Strongest;
  if (mode == kModeLast) return VelodyneReturn::Last;
  if (block % 2 == 0)
    return (u16(other) == 0 || sameReturn(ret, other)) ? VelodyneReturn::DualBoth
                                                       : VelodyneReturn::DualLast;
  return ret[2] > other[2] ? VelodyneReturn::DualStrongest : VelodyneReturn::DualSecond;
}

/// One return: range and field-of-view filters, then the calibration model of the ROS driver
/// (vertical/horizontal origin offsets, two-point distance corrections, focal intensity).
void VelodyneDecoder::emit(int laser, const std::uint8_t* ret, float azimuth_f,
                           bool check_point_fov, double time, VelodyneReturn type) {
  const LaserTerms& c = lasers_[laser];
  const std::uint16_t raw = u16(ret);
  float distance = static_cast<float>(raw) * distance_resolution_;
  if (distance > 1e-6f) distance += c.dist;
  if (!(distance > options_.min_range && distance < options_.max_range)) return;
  if (azimuth_f < 0) azimuth_f += kCentiDegrees;
  const int azimuth = static_cast<std::uint16_t>(std::round(azimuth_f)) % kCentiDegrees;
  if (check_point_fov && !inFov(azimuth)) return;
  const float cos_a = azimuthTable().cos_az[azimuth], sin_a = azimuthTable().sin_az[azimuth];
  float xy = distance * c.cos_vert - c.vert_offset * c.sin_vert;
  float corr_x = 0, corr_y = 0;
  if (c.two_point) {  // distance correction interpolated between two calibration ranges
    const float xx = std::abs(xy * sin_a - c.horiz_offset * cos_a);
    const float yy = std::abs(xy * cos_a + c.horiz_offset * sin_a);
    corr_x = (c.dist - c.dist_x) * (xx - 2.4f) / (25.04f - 2.4f) + c.dist_x - c.dist;
    corr_y = (c.dist - c.dist_y) * (yy - 1.93f) / (25.04f - 1.93f) + c.dist_y - c.dist;
  }
  xy = (distance + corr_x) * c.cos_vert - c.vert_offset * c.sin_vert;
  const float vx = xy * sin_a - c.horiz_offset * cos_a;  // Velodyne frame: x right, y forward
  const float dy = distance + corr_y;
  xy = dy * c.cos_vert - c.vert_offset * c.sin_vert;
  const float vy = xy * cos_a + c.horiz_offset * sin_a;
  const float z = dy * c.sin_vert + c.vert_offset * c.cos_vert;
  float intensity = ret[2];
  if (c.focal_slope != 0) {
    const float sqr = (1 - raw / 65535.0f) * (1 - raw / 65535.0f);
    intensity += c.focal_slope * std::abs(c.focal_offset - 256 * sqr);
  }
  intensity = std::min(std::max(intensity, c.min_intensity), c.max_intensity);
  LabeledCloud& cloud = scan_.cloud;
  cloud.points.emplace_back(vy, -vx, z);  // ROS: x forward, y left
  cloud.classes.push_back(0);
  cloud.intensity.push_back(intensity);
  cloud.timestamps.push_back(time);
  scan_.ring.push_back(c.ring);
  scan_.return_type.push_back(static_cast<std::uint8_t>(type));
  azimuth_cd_.push_back(static_cast<std::uint16_t>(azimuth));
}

/// VLP-16: each block holds two firing sequences of the 16 lasers (2.304 µs apart, sequences
/// 55.296 µs apart); dual return pairs blocks, so a pair covers two sequences.
void VelodyneDecoder::decode16(const std::uint8_t* packet, double time, std::uint8_t mode) {
  const bool dual = mode == kModeDual;
  const BlockAzimuths az = blockAzimuths(packet, kBlocks, dual, kBlocks - (dual ? 1 : 0) - 1);
  for (int b = 0; b < kBlocks; ++b) {
    if (skip_[b]) continue;
    if (!(fov_min_cd_ < fov_max_cd_ ? inFov(az.azimuth[b]) : fov_min_cd_ > fov_max_cd_)) continue;
    const std::uint8_t* data = packet + b * kBlockBytes + 4;
    const std::uint8_t* pair = packet + (b ^ 1) * kBlockBytes + 4;
    for (int firing = 0; firing < 2; ++firing) {
      for (int laser = 0; laser < 16; ++laser) {
        const int k = (firing * 16 + laser) * 3;
        if (u16(data + k) == 0 || (dual && b % 2 == 1 && sameReturn(data + k, pair + k))) continue;
        const int sequence = dual ? (b - b % 2) + firing : b * 2 + firing;
        const double offset = sequence * 55.296e-6 + laser * 2.304e-6;
        const float step = az.diff[b] * ((laser * 2.304f) + (firing * 55.296f)) / 110.592f;
        const float azimuth =
            options_.exact_azimuth
                ? exactAzimuth(packet, b, dual, offset, laser)
                : static_cast<float>(static_cast<double>(az.azimuth[b] + step) - lasers_[laser].rot_cd);
        emit(laser, data + k, azimuth, true, time + offset,
             returnType(mode, b, data + k, pair + k));
      }
    }
  }
}

/// VLP-32C and HDL-32E: each block is one firing sequence of the 32 lasers (VLP-32C: pairs
/// every 2.304 µs, 55.296 µs a sequence; HDL-32E: one laser every 1.152 µs, 46.08 µs).
void VelodyneDecoder::decode32(const std::uint8_t* packet, double time, std::uint8_t mode) {
  const bool dual = mode == kModeDual;
  const bool hdl = *model_ == VelodyneModel::HDL32E;
  const float channel = hdl ? 1.152f : 2.304f, sequence_us = hdl ? 46.08f : 55.296f;
  const BlockAzimuths az = blockAzimuths(packet, kBlocks, dual, kBlocks - (dual ? 4 : 0) - 1);
  for (int b = 0; b < kBlocks; ++b) {
    if (skip_[b]) continue;
    const std::uint8_t* data = packet + b * kBlockBytes + 4;
    const std::uint8_t* pair = packet + (b ^ 1) * kBlockBytes + 4;
    if (!inFov(u16(data - 2))) continue;  // the driver filters these models by block azimuth
    const int sequence = dual ? b / 2 : b;
    for (int laser = 0; laser < 32; ++laser) {
      const int k = laser * 3;
      if (u16(data + k) == 0 || (dual && b % 2 == 1 && sameReturn(data + k, pair + k))) continue;
      const double offset =
          sequence * sequence_us * 1e-6 + (hdl ? laser : laser / 2) * channel * 1e-6;
      const float step = az.diff[b] * channel / sequence_us * static_cast<float>(laser);
      const float azimuth =
          options_.exact_azimuth
              ? exactAzimuth(packet, b, dual, offset, laser)
              : static_cast<float>(static_cast<double>(az.azimuth[b] + step) - lasers_[laser].rot_cd);
      emit(laser, data + k, azimuth, false, time + offset, returnType(mode, b, data + k, pair + k));
    }
  }
}

/// VLS-128: four blocks (one per bank of 32 lasers) make a firing sequence of 16 groups of 8
/// lasers, 2.665 µs apart, 53.3 µs a sequence; a packet holds three sequences in single
/// return mode and one (eight blocks, returns paired) in dual.
void VelodyneDecoder::decode128(const std::uint8_t* packet, double time, std::uint8_t mode) {
  static const Vls128Phase phase;
  const bool dual = mode == kModeDual;
  const int used = dual ? 8 : kBlocks;
  const BlockAzimuths az = blockAzimuths(packet, used, dual, kBlocks - (dual ? 4 : 0) - 1);
  for (int b = 0; b < used; ++b) {
    if (skip_[b]) continue;
    if (!(fov_min_cd_ < fov_max_cd_ ? inFov(az.azimuth[b]) : fov_min_cd_ > fov_max_cd_)) continue;
    const std::uint8_t* data = packet + b * kBlockBytes + 4;
    const std::uint8_t* pair = packet + (b ^ 1) * kBlockBytes + 4;
    const int bank = bankOf(u16(data - 4));
    for (int j = 0; j < 32; ++j) {
      const int k = j * 3;
      if (u16(data + k) == 0 || (dual && b % 2 == 1 && sameReturn(data + k, pair + k))) continue;
      const int laser = bank * 32 + j, group = laser / 8;
      const int sequence = dual ? 0 : b / 4;
      const double offset = sequence * 53.3e-6 + (group + laser / 64) * 2.665e-6 - 8.7e-6;
      const float azimuth =
          options_.exact_azimuth
              ? exactAzimuth(packet, b, dual, offset, laser)
              : static_cast<float>(static_cast<double>(az.azimuth[b] + az.diff[b] * phase.of_group[group]) -
                                   lasers_[laser].rot_cd);
      emit(laser, data + k, azimuth, true, time + offset, returnType(mode, b, data + k, pair + k));
    }
  }
}

/// Time (s into the packet) of the first firing of a block's sequence, as in the timing
/// tables above.
double VelodyneDecoder::blockStart(int b, bool dual) const {
  switch (*model_) {
    case VelodyneModel::VLP16: return (dual ? b - b % 2 : 2 * b) * 55.296e-6;
    case VelodyneModel::VLP32C: return (dual ? b / 2 : b) * 55.296e-6;
    case VelodyneModel::HDL32E: return (dual ? b / 2 : b) * 46.08e-6;
    case VelodyneModel::VLS128: return (dual ? 0 : b / 4) * 53.3e-6 - 8.7e-6;
  }
  return 0;
}

/// The rotor speed over the packet, from its first and last firing sequence; a packet of one
/// sequence (VLS-128 dual return), or one whose azimuth jumps (a restricted field of view),
/// keeps the speed from the previous packet through the packets' µs time stamps.
void VelodyneDecoder::fitRotor(const std::uint8_t* p, std::uint8_t mode) {
  constexpr double kFastest = 25 * 36000.0;  // 0.01°/s: the sensors spin at 20 Hz at most
  constexpr std::int64_t kHourUs = 3600LL * 1000000;
  const bool dual = mode == kModeDual;
  const int last = dual ? 10 : 11;
  const double t0 = blockStart(0, dual), t1 = blockStart(last, dual);
  const std::uint16_t az0 = u16(p + 2), az1 = u16(p + last * kBlockBytes + 2);
  const std::int64_t stamp = static_cast<std::int64_t>(p[1200] | (p[1201] << 8) | (p[1202] << 16)) |
                             (static_cast<std::int64_t>(p[1203]) << 24);
  double rate = -1;
  if (t1 > t0) rate = ((kCentiDegrees + az1 - az0) % kCentiDegrees) / (t1 - t0);
  if (!(rate >= 0 && rate < kFastest) && prev_stamp_us_ >= 0) {
    const std::int64_t dt = ((stamp - prev_stamp_us_) % kHourUs + kHourUs) % kHourUs;
    if (dt > 0) rate = ((kCentiDegrees + az0 - prev_azimuth_) % kCentiDegrees) / (dt * 1e-6);
  }
  if (rate >= 0 && rate < kFastest) rotor_rate_ = rate;
  prev_stamp_us_ = stamp;
  prev_azimuth_ = az0;
}

}  // namespace hazmap::velodyne_detail
