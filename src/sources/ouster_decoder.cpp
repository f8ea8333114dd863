// Ouster packets → scans. Columns are gathered by measurement id into a range image of the
// current frame; a packet of another frame id completes the scan (like ouster-sdk's
// ScanBatcher), a packet of the previous frame arriving late is dropped. Like ouster-sdk, what does
// not fit (a datagram of another size, a column beyond the frame, a late or foreign packet) is
// skipped, never fatal: counted in DecoderQuirks and warned once.
#include <fmt/format.h>

#include <deque>
#include <utility>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/ouster.hpp"
#include "sources/ouster_packet.hpp"

namespace hazmap {
namespace {

constexpr std::size_t kImuPacketSize = kOusterImuPacketSize;  // IMU packets share the stream: not odd
constexpr std::uint64_t kYear2001Ns = 978'307'200ull * 1'000'000'000ull;
enum class ColumnState : std::uint8_t { Missing, Valid, Invalid };

}  // namespace

struct OusterDecoder::Impl {
  OusterMetadata meta;
  OusterDecoderOptions options;
  ouster_detail::PacketLayout layout;
  ouster_detail::XyzLut lut;
  std::uint64_t serial = 0;  // 0: not checked
  bool use_reflectivity = false;

  // The frame being assembled: a range image indexed (column · pixels + row).
  int frame_id = -1;
  std::vector<std::uint32_t> range, range2;
  std::vector<std::uint16_t> intensity, intensity2;
  std::vector<std::uint64_t> column_time;
  std::vector<ColumnState> state;
  std::uint32_t columns_received = 0;
  std::uint32_t columns_skipped = 0;  // odd columns of this frame (DecoderQuirks)
  double clock_offset = 0.0;  // seconds added to the sensor's timestamps
  bool clock_known = false;   // clock_offset set by a lidar packet
  std::vector<ImuSample> imu;

  std::deque<DecodedScan> ready;
  OusterDecoderStats stats;
  DecoderQuirks& quirks;  // the decoder's

  Impl(const OusterMetadata& m, const OusterDecoderOptions& o, DecoderQuirks& q)
      : meta(m), options(o), layout(m), lut(ouster_detail::makeXyzLut(m)), quirks(q) {
    const std::size_t n = std::size_t{m.columns_per_frame} * m.pixels_per_column;
    range.resize(n);
    intensity.resize(n);
    if (layout.dual) range2.resize(n), intensity2.resize(n);
    column_time.resize(m.columns_per_frame);
    state.assign(m.columns_per_frame, ColumnState::Missing);
    use_reflectivity = o.intensity == OusterDecoderOptions::Intensity::Reflectivity;
    if (!m.serial.empty() && m.serial.find_first_not_of("0123456789") == std::string::npos &&
        m.serial.size() < 16)
      serial = std::stoull(m.serial);
  }

  bool foreign(const std::uint8_t* packet) const {
    if (meta.profile == OusterProfile::Legacy) return false;  // legacy packets carry neither
    if (meta.initialization_id != 0 && layout.initId(packet) != (meta.initialization_id & 0xffffffu)) return true;
    return serial != 0 && layout.serial(packet) != serial;
  }

  void add(std::span<const std::uint8_t> payload, double packet_time, const std::string& where) {
    if (payload.size() == kImuPacketSize && layout.packet_size != kImuPacketSize) addImu(payload, packet_time, where);
    if (payload.size() != layout.packet_size || layout.packetType(payload.data()) != 1) {
      ++stats.other_packets;
      stats.last_other_size = payload.size();
      if (payload.size() != kImuPacketSize && payload.size() != layout.packet_size)
        quirks.note(fmt::format("Ouster datagrams of another size than {}'s lidar packets ({} bytes; truncated, or "
                                "another sensor or mode) skipped", meta.describe(), layout.packet_size), where);
      return;
    }
    const std::uint8_t* packet = payload.data();
    if (foreign(packet)) {
      ++stats.foreign_packets;
      quirks.note("Ouster packets of another sensor (initialization id or serial number) skipped", where);
      return;
    }
    ++stats.lidar_packets;
    ++quirks.decoded_packets;
    const std::uint16_t f_id = layout.frameId(packet);
    if (frame_id >= 0 && static_cast<std::uint16_t>(f_id + 1) == frame_id) {
      ++stats.late_packets;
      quirks.note("Ouster packets of an already completed frame (out of order) skipped", where);
      return;
    }
    if (frame_id >= 0 && f_id != frame_id) finishFrame();
    if (frame_id < 0) startFrame(f_id, packet, packet_time);
    for (std::size_t i = 0; i < layout.columns; ++i) addColumn(layout.column(packet, i), where);
  }

  /// The IMU's clock is the lidar's: its time gets the lidar columns' offset (its own packet's
  /// before the first lidar packet).
  void addImu(std::span<const std::uint8_t> payload, double packet_time, const std::string& where) {
    const auto packet = decodeOusterImuPacket(payload, meta);
    if (!packet) {
      quirks.note("Ouster IMU packets with non-finite values skipped", where);
      return;
    }
    const double sensor_time = static_cast<double>(packet->gyro_time_ns) * 1e-9;
    double offset = clock_offset;
    if (!clock_known) {
      bool sensor_clock = options.clock == OusterDecoderOptions::Clock::Sensor;
      if (options.clock == OusterDecoderOptions::Clock::Auto) sensor_clock = packet->gyro_time_ns >= kYear2001Ns;
      offset = sensor_clock ? 0.0 : packet_time - sensor_time;
    }
    ImuSample sample = packet->sample;
    sample.time = sensor_time + offset;
    imu.push_back(sample);
    ++stats.imu_packets;
  }

  void startFrame(std::uint16_t f_id, const std::uint8_t* packet, double packet_time) {
    frame_id = f_id;
    std::fill(state.begin(), state.end(), ColumnState::Missing);
    columns_received = 0;
    columns_skipped = 0;
    const std::uint64_t last_ts = ouster_detail::PacketLayout::timestamp(layout.column(packet, layout.columns - 1));
    bool sensor_clock = options.clock == OusterDecoderOptions::Clock::Sensor;
    if (options.clock == OusterDecoderOptions::Clock::Auto) sensor_clock = last_ts >= kYear2001Ns;
    // A packet leaves the sensor right after its last column is measured.
    clock_offset = sensor_clock ? 0.0 : packet_time - static_cast<double>(last_ts) * 1e-9;
    clock_known = true;
  }

  void addColumn(const std::uint8_t* col, const std::string& where) {
    const std::uint16_t m_id = ouster_detail::PacketLayout::measurementId(col);
    if (!layout.valid(col)) {
      ++stats.invalid_columns;
      if (m_id < meta.columns_per_frame && state[m_id] == ColumnState::Missing) {
        state[m_id] = ColumnState::Invalid;
        ++columns_received;
      }
      return;
    }
    if (m_id >= meta.columns_per_frame) {  // ouster-sdk's batcher drops these columns too
      quirks.note(fmt::format("Ouster columns with a measurement id beyond the {}-column frame (lidar_mode {}) "
                              "skipped", meta.columns_per_frame, meta.lidar_mode), where);
      ++columns_skipped;  // received, though unusable: the scan is not incomplete for it
      return;
    }
    if (state[m_id] == ColumnState::Missing) ++columns_received;
    state[m_id] = ColumnState::Valid;
    column_time[m_id] = ouster_detail::PacketLayout::timestamp(col);
    const std::size_t base = std::size_t{m_id} * layout.pixels;
    layout.decodeColumn(col, use_reflectivity, &range[base], &intensity[base],
                        layout.dual ? &range2[base] : nullptr, layout.dual ? &intensity2[base] : nullptr);
  }

  void emitPoint(DecodedScan& scan, std::size_t pixel, std::uint32_t range_mm, std::uint16_t value,
                 double time, std::uint8_t return_type) const {
    const float r = static_cast<float>(range_mm);
    const float* d = &lut.direction[pixel * 3];
    const float* o = &lut.offset[pixel * 3];
    scan.cloud.points.emplace_back(r * d[0] + o[0], r * d[1] + o[1], r * d[2] + o[2]);
    scan.cloud.intensity.push_back(static_cast<float>(value));
    scan.cloud.timestamps.push_back(time);
    scan.ring.push_back(static_cast<std::uint16_t>(pixel % layout.pixels));
    scan.return_type.push_back(return_type);
  }

  /// The range image as a cloud, columns in time order from the column window's start.
  DecodedScan buildScan() const {
    DecodedScan scan;
    const std::size_t h = layout.pixels, w = meta.columns_per_frame;
    const bool second = layout.dual && options.second_return;
    scan.cloud.reserve(columns_received * h * (second ? 2 : 1));
    bool first = true;
    for (std::size_t k = 0; k < w; ++k) {
      const std::size_t c = (meta.column_window_first + k) % w;
      if (state[c] != ColumnState::Valid) continue;
      const double time = static_cast<double>(column_time[c]) * 1e-9 + clock_offset;
      if (first) scan.stamp = time, first = false;
      for (std::size_t r = 0; r < h; ++r) {
        const std::size_t pixel = c * h + r;
        if (range[pixel] != 0) emitPoint(scan, pixel, range[pixel], intensity[pixel], time, 0);
        if (second && range2[pixel] != 0) emitPoint(scan, pixel, range2[pixel], intensity2[pixel], time, 1);
      }
    }
    scan.cloud.classes.assign(scan.cloud.points.size(), 0);
    return scan;
  }

  void finishFrame() {
    if (frame_id < 0) return;
    const bool complete = columns_received + columns_skipped >= meta.columnsInWindow();
    if (complete || options.keep_incomplete_scans) {
      ready.push_back(buildScan());
      ++stats.scans_emitted;
    } else {
      ++stats.incomplete_scans_dropped;
    }
    frame_id = -1;
  }
};

OusterDecoder::OusterDecoder(const OusterMetadata& metadata, const OusterDecoderOptions& options)
    : impl_(std::make_unique<Impl>(metadata, options, quirks_)) {}
OusterDecoder::~OusterDecoder() = default;

void OusterDecoder::addPacket(std::span<const std::uint8_t> payload, double packet_time,
                              const std::string& where) {
  impl_->add(payload, packet_time, where);
}

std::optional<DecodedScan> OusterDecoder::takeScan() {
  if (impl_->ready.empty()) return std::nullopt;
  DecodedScan scan = std::move(impl_->ready.front());
  impl_->ready.pop_front();
  return scan;
}

std::optional<DecodedScan> OusterDecoder::flush() {
  impl_->finishFrame();
  return takeScan();
}

std::vector<ImuSample> OusterDecoder::takeImu() { return std::exchange(impl_->imu, {}); }

std::string OusterDecoder::describe() const { return impl_->meta.describe(); }

std::vector<std::string> OusterDecoder::notices(const std::string& where) const {
  const OusterDecoderStats& s = impl_->stats;
  std::vector<std::string> out;
  const auto n = [](std::uint64_t v) { return std::to_string(v); };
  if (s.lidar_packets == 0 && s.other_packets > 0)
    out.push_back(where + ": no packet of " + impl_->meta.describe() + "'s lidar packet size (" +
                  n(impl_->layout.packet_size) + " bytes) among " + n(s.other_packets) +
                  " packets (the last of " + n(s.last_other_size) +
                  " bytes): the metadata does not belong to these packets");
  if (s.incomplete_scans_dropped > 0)
    out.push_back(where + ": " + n(s.incomplete_scans_dropped) +
                  " incomplete Ouster scans dropped (started or ended mid-rotation, or packets lost)");
  if (s.late_packets > 0)
    out.push_back(where + ": " + n(s.late_packets) + " Ouster packets arrived after their scan was complete");
  if (s.foreign_packets > 0)
    out.push_back(where + ": " + n(s.foreign_packets) +
                  " Ouster packets of another sensor (initialization id or serial number differ from the metadata's)");
  return out;
}
const OusterDecoderStats& OusterDecoder::stats() const { return impl_->stats; }
const OusterMetadata& OusterDecoder::metadata() const { return impl_->meta; }

std::unique_ptr<OusterDecoder> makeOusterDecoder(const OusterMetadata& metadata,
                                                 const OusterDecoderOptions& options) {
  return std::make_unique<OusterDecoder>(metadata, options);
}

}  // namespace hazmap
