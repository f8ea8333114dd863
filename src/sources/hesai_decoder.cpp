// Hesai data packets → scans. Per firing (the blocks of one firing: 1 in single return, 2 in
// dual, 3 in triple) and channel: the returns are range-filtered; of returns identical to
// another of the same firing (distance and reflectivity) only the last is kept, and a return
// other than the last is dropped when another lies within dual_return_distance_threshold — as
// nebula does. A point's azimuth is its block's azimuth plus the channel's offset, not rounded
// (nebula's reference clouds keep the offsets' fractions of 0.01°). A point belongs to the scan
// its own azimuth falls in, counted in turns from the cut angle, so a scan ends exactly at the
// cut whatever the channels' offsets; a scan is complete once the block azimuth has carried
// every channel past its end (this is where nebula's overlap handling puts every point too).
//
// Tolerance, as the drivers do: nebula skips a packet shorter than its model's layout and keeps
// decoding; azimuth 36000 is taken modulo 36000 (as the Velodyne drivers and nebula's angle
// normalisation do); a firing whose azimuth goes back against the rotation is out of order and
// skipped, as is one with an azimuth above 36000; a packet of another model is skipped. Each
// kind is counted in DecoderQuirks and warned once.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <map>
#include <numbers>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"
#include "sources/hesai_layout.hpp"

namespace hazmap::hesai_detail {

namespace {

constexpr int kCentiDegrees = 36000;

struct Channel {
  float cos_el, sin_el, azimuth_offset;  // degrees
  float cos_offset, sin_offset;          // of the azimuth offset
  std::uint16_t ring;
};

class HesaiDecoder final : public PacketDecoder {
 public:
  explicit HesaiDecoder(const HesaiOptions& options) : options_(options) {
    if (!(options.min_range >= 0 && options.max_range > options.min_range))
      fail("Hesai decoder", "min_range/max_range must satisfy 0 <= min < max");
    if (!(options.cut_angle >= 0 && options.cut_angle < 360) || !(options.fov_min >= 0 && options.fov_min <= 360) ||
        !(options.fov_max >= 0 && options.fov_max <= 360))
      fail("Hesai decoder", "cut_angle must be in [0, 360) and fov_min/fov_max in [0, 360] degrees");
    if (!(options.dual_return_distance_threshold >= 0))
      fail("Hesai decoder", "dual_return_distance_threshold must be >= 0");
    full_fov_ = options.fov_min == 0 && options.fov_max == 360;
    if (options.model) setUp(*options.model);
  }

  void addPacket(std::span<const std::uint8_t> payload, double packet_time, const std::string& where) override;
  std::optional<DecodedScan> takeScan() override {
    if (ready_.empty()) return std::nullopt;
    DecodedScan s = std::move(ready_.front());
    ready_.pop_front();
    return s;
  }
  std::optional<DecodedScan> flush() override {
    if (ready_.empty() && !open_.empty()) {  // the rotation the input ended in, one turn at a time
      finish(open_.begin()->second);
      open_.erase(open_.begin());
      current_ = nullptr;
    }
    return takeScan();
  }
  std::string describe() const override {
    if (!model_) return "Hesai (no data packet yet)";
    return fmt::format("Hesai {} ({}), {} angle corrections", hesaiModelName(*model_), modeName(last_mode_),
                       calibration_source_);
  }

 private:
  static std::string modeName(std::uint8_t mode) {
    switch (mode) {
      case 0x37: return "strongest return";
      case 0x38: return "last return";
      case 0x39: return "last+strongest dual return";
      case 0: return "no data yet";
      default: return fmt::format("{}-return mode 0x{:02x}", returnsOfMode(mode), mode);
    }
  }
  void setUp(HesaiModel model);
  bool packetFits(std::span<const std::uint8_t> p, const std::string& where);
  bool advance(std::uint16_t azimuth, const std::string& where);
  void decodeFiring(const std::uint8_t* packet, int first_block, int returns, std::uint16_t azimuth,
                    float unit, double time);
  bool keep(const std::uint8_t* const* units, int r, int returns, float unit, float distance) const;
  DecodedScan* scanFor(std::int64_t index);
  void closeScans(std::uint16_t azimuth);
  void finish(DecodedScan& scan) {
    scan.cloud.classes.assign(scan.cloud.points.size(), 0);
    last_size_ = std::max(last_size_, scan.cloud.points.size());
    scan.stamp = scan.cloud.timestamps.empty() ? 0.0 : scan.cloud.timestamps.front();
    ready_.push_back(std::move(scan));
  }
  bool inFov(float azimuth_deg) const {
    const float a = azimuth_deg - 360.0f * std::floor(azimuth_deg / 360.0f);
    const auto lo = static_cast<float>(options_.fov_min), hi = static_cast<float>(options_.fov_max);
    return lo <= hi ? a >= lo && a <= hi : a >= lo || a <= hi;
  }

  HesaiOptions options_;
  std::optional<HesaiModel> model_;
  const HesaiLayout* layout_ = nullptr;
  std::vector<Channel> channels_;
  float min_offset_ = 0;  // smallest channel azimuth offset (degrees)
  float min_range_ = 0, max_range_ = 0;
  std::string calibration_source_;
  std::uint8_t last_mode_ = 0;
  std::int64_t turn_ = 0;  // block azimuth, unwrapped: turn_ · 360° + prev_azimuth_
  int prev_azimuth_ = -1;
  std::map<std::int64_t, DecodedScan> open_;  // scans being filled, by turn index
  DecodedScan* current_ = nullptr;            // open_[current_index_], the one most points go to
  std::int64_t current_index_ = 0;
  bool full_fov_ = true;
  std::size_t last_size_ = 0;  // the largest scan so far: what a new one reserves
  std::int64_t closed_below_ = std::numeric_limits<std::int64_t>::min();
  std::deque<DecodedScan> ready_;
};

void HesaiDecoder::setUp(HesaiModel model) {
  const HesaiCalibration cal = options_.calibration_file.empty()
                                   ? hesaiDefaultCalibration(model)
                                   : loadHesaiCalibration(options_.calibration_file, model);
  model_ = model;
  layout_ = &hesaiLayout(model);
  calibration_source_ = cal.source;
  min_range_ = std::max(layout_->min_range, static_cast<float>(options_.min_range));
  max_range_ = std::min(layout_->max_range, static_cast<float>(options_.max_range));
  std::vector<std::size_t> order(cal.elevation_deg.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return cal.elevation_deg[a] < cal.elevation_deg[b]; });
  channels_.assign(order.size(), {});
  constexpr float kRad = static_cast<float>(std::numbers::pi / 180.0);
  for (std::size_t ring = 0; ring < order.size(); ++ring) {
    const std::size_t c = order[ring];
    const float el = static_cast<float>(cal.elevation_deg[c]) * kRad;
    const double offset = cal.azimuth_deg[c] * std::numbers::pi / 180;
    channels_[c] = {std::cos(el),
                    std::sin(el),
                    static_cast<float>(cal.azimuth_deg[c]),
                    static_cast<float>(std::cos(offset)),
                    static_cast<float>(std::sin(offset)),
                    static_cast<std::uint16_t>(ring)};
  }
  min_offset_ = channels_[0].azimuth_offset;
  for (const Channel& c : channels_) min_offset_ = std::min(min_offset_, c.azimuth_offset);
}

/// The packet's model must be the configured one (or the first packet's), its return mode known.
bool HesaiDecoder::packetFits(std::span<const std::uint8_t> p, const std::string& where) {
  const auto model = hesaiModelOfPacket(p);
  if (!model) {
    quirks_.note(model_ && p.size() < layout_->size && p.size() >= 12 && (p[0] == 0xee || p[0] == 0xff)
                     ? fmt::format("Hesai datagrams shorter than a {} data packet ({} bytes; truncated) skipped",
                                   hesaiModelName(*model_), layout_->size)
                     : std::string("datagrams that are no Hesai data packet (unknown layout or size) skipped"),
                 where);
    return false;
  }
  if (!model_) setUp(*model);
  if (*model != *model_) {
    quirks_.note(fmt::format("Hesai packets of another model ({}, expected {}) skipped", hesaiModelName(*model),
                             hesaiModelName(*model_)),
                 where);
    return false;
  }
  const int returns = returnsOfMode(p[layout_->return_mode_at]);
  if (returns == 0 || layout_->blocks % returns != 0 || (layout_->distance_unit_at >= 0 && p[layout_->distance_unit_at] == 0)) {
    quirks_.note(fmt::format("Hesai packets with an unknown return mode (e.g. 0x{:02x}) or no distance unit skipped",
                             p[layout_->return_mode_at]),
                 where);
    return false;
  }
  return true;
}

void HesaiDecoder::addPacket(std::span<const std::uint8_t> payload, double packet_time, const std::string& where) {
  constexpr std::size_t kGpsPacketSize = 512;  // the sensors' GPS/PPS status packets: no odd input
  if (payload.size() == kGpsPacketSize || !packetFits(payload, where)) return;
  const std::uint8_t* p = payload.data();
  last_mode_ = p[layout_->return_mode_at];
  const int returns = returnsOfMode(last_mode_);
  const float unit = layout_->distance_unit_at < 0 ? 0.004f : static_cast<float>(p[layout_->distance_unit_at] / 1000.0);
  bool decoded = false;
  for (int b = 0; b < layout_->blocks; b += returns) {
    const std::uint8_t* block = p + layout_->header + static_cast<std::size_t>(b) * layout_->block_bytes;
    if (layout_->azimuth_at == 2 && (block[0] != 0xff || block[1] != 0xee)) {
      quirks_.note("Hesai blocks without their 0xFFEE start skipped", where);
      continue;
    }
    std::uint16_t azimuth = u16(block + layout_->azimuth_at);
    if (azimuth == kCentiDegrees) {
      azimuth = 0;
      quirks_.note("Hesai block azimuths of 36000 wrapped to 0", where);
    } else if (azimuth > kCentiDegrees) {
      quirks_.note("Hesai blocks with an azimuth above 36000 skipped", where);
      continue;
    }
    if (!advance(azimuth, where)) continue;
    decodeFiring(p, b, returns, azimuth, unit, packet_time);
    closeScans(azimuth);
    decoded = true;
  }
  if (decoded) ++quirks_.decoded_packets;
}

/// Unwraps the block azimuth; false for a firing that goes back against the rotation.
bool HesaiDecoder::advance(std::uint16_t azimuth, const std::string& where) {
  if (prev_azimuth_ >= 0) {
    const int step = azimuth - prev_azimuth_;
    if (step < -kCentiDegrees / 2) {
      ++turn_;
    } else if (step < 0 || step > kCentiDegrees / 2) {
      quirks_.note("Hesai firings out of azimuth order skipped", where);
      return false;
    }
  }
  prev_azimuth_ = azimuth;
  return true;
}

/// nebula's multi-return filters for return r of a firing's `units`.
bool HesaiDecoder::keep(const std::uint8_t* const* units, int r, int returns, float unit, float distance) const {
  if (r == returns - 1) return true;
  const auto threshold = static_cast<float>(options_.dual_return_distance_threshold);
  for (int k = 0; k < returns; ++k) {
    if (k == r) continue;
    if (u16(units[k]) == u16(units[r]) && units[k][2] == units[r][2]) return false;  // identical: keep the last
    if (std::abs(static_cast<float>(u16(units[k])) * unit - distance) < threshold) return false;
  }
  return true;
}

/// One firing's points. The azimuth's sine and cosine come from the block's and the channel
/// offset's by the angle-addition formulas (a sine per point would cost most of the decoding);
/// the scan a point belongs to from its azimuth in degrees, in float as nebula computes it.
void HesaiDecoder::decodeFiring(const std::uint8_t* packet, int first_block, int returns, std::uint16_t azimuth,
                                float unit, double time) {
  const HesaiLayout& l = *layout_;
  const float block_deg = static_cast<float>(azimuth / 100.0);
  const auto cut = static_cast<float>(options_.cut_angle);
  const double block_rad = azimuth * std::numbers::pi / 18000.0;
  const auto sin_block = static_cast<float>(std::sin(block_rad)), cos_block = static_cast<float>(std::cos(block_rad));
  const double block_time = time + l.blockOffsetNs(first_block, returns) * 1e-9;
  const std::uint8_t* first = packet + l.header + static_cast<std::size_t>(first_block) * l.block_bytes + l.azimuth_at + 2;
  const std::uint8_t* units[3];
  for (int c = 0; c < l.channels; ++c) {
    bool any = false;  // most units of a packet are empty (no echo): skip them first
    for (int r = 0; r < returns; ++r) {
      units[r] = first + static_cast<std::size_t>(r) * l.block_bytes + c * l.unit;
      any = any || units[r][0] != 0 || units[r][1] != 0;
    }
    if (!any) continue;
    const Channel& ch = channels_[static_cast<std::size_t>(c)];
    const float azimuth_deg = block_deg + ch.azimuth_offset;
    if (!full_fov_ && !inFov(azimuth_deg)) continue;
    const float from_cut = azimuth_deg - cut;
    const std::int64_t index = turn_ + (from_cut < 0 ? -1 : from_cut >= 360.0f ? 1 : 0);
    const float sin_az = sin_block * ch.cos_offset + cos_block * ch.sin_offset;
    const float cos_az = cos_block * ch.cos_offset - sin_block * ch.sin_offset;
    const double point_time = block_time + l.channelOffsetNs(c) * 1e-9;
    for (int r = 0; r < returns; ++r) {
      const std::uint16_t raw = u16(units[r]);
      const float distance = static_cast<float>(raw) * unit;
      if (raw == 0 || distance < min_range_ || distance > max_range_ || !keep(units, r, returns, unit, distance))
        continue;
      DecodedScan* s = scanFor(index);
      if (!s) continue;
      const float xy = distance * ch.cos_el;
      // Hesai's frame: azimuth 0 along y, clockwise seen from above (x right); ROS: x forward, y left.
      s->cloud.points.emplace_back(xy * cos_az, -xy * sin_az, distance * ch.sin_el);
      s->cloud.intensity.push_back(units[r][2]);
      s->cloud.timestamps.push_back(point_time);
      s->ring.push_back(ch.ring);
      s->return_type.push_back(static_cast<std::uint8_t>(returns == 1 ? 0 : r + 1));
    }
  }
}

/// The open scan of this turn index (made when new); nullptr for one already complete.
DecodedScan* HesaiDecoder::scanFor(std::int64_t index) {
  if (current_ && index == current_index_) return current_;
  if (index < closed_below_) return nullptr;  // cannot happen with azimuths in order (advance)
  auto [it, made] = open_.try_emplace(index);
  if (made) {
    DecodedScan& s = it->second;
    s.cloud.enableIntensity();
    s.cloud.enableTimestamps();
    s.cloud.points.reserve(last_size_);
    s.cloud.intensity.reserve(last_size_);
    s.cloud.timestamps.reserve(last_size_);
    s.ring.reserve(last_size_);
    s.return_type.reserve(last_size_);
  }
  current_ = &it->second;
  current_index_ = index;
  return current_;
}

/// Scans whose end every channel has passed at this block azimuth are complete.
void HesaiDecoder::closeScans(std::uint16_t azimuth) {
  // The same float arithmetic as the points' azimuths: the channel of the smallest offset is
  // the last to pass the cut, and no point can fall behind it by rounding.
  const float passed = (static_cast<float>(azimuth / 100.0) + min_offset_ - static_cast<float>(options_.cut_angle)) / 360.0f;
  const std::int64_t complete_below = turn_ + static_cast<std::int64_t>(std::floor(passed));
  while (!open_.empty() && open_.begin()->first < complete_below) {
    if (current_ == &open_.begin()->second) current_ = nullptr;
    finish(open_.begin()->second);
    open_.erase(open_.begin());
  }
  closed_below_ = std::max(closed_below_, complete_below);
}

}  // namespace

}  // namespace hazmap::hesai_detail

namespace hazmap {

std::unique_ptr<PacketDecoder> makeHesaiDecoder(const HesaiOptions& options) {
  return std::make_unique<hesai_detail::HesaiDecoder>(options);
}

}  // namespace hazmap
