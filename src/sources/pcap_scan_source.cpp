// A packet capture (.pcap) as a ScanSource. Which sensor sent it is sniffed from the datagrams:
// Velodyne data packets are 1206-byte payloads (port 2368 by default), Hesai data packets (port
// 2368 too) start with 0xEEFF (0xFFEE on the Pandar40P) and have their model's size, Ouster lidar packets go to
// port 7502 by default and need the sensor's metadata JSON (by default the .json next to the
// capture) to be decoded.
#include <algorithm>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/hesai.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "hazmap/sources/velodyne.hpp"
#include "sources/assembled_scans.hpp"
#include "sources/packet_decoders.hpp"
#include "sources/scan_assembler.hpp"

namespace hazmap::sources {

namespace {

namespace fs = std::filesystem;

enum class CaptureSensor { Velodyne, Hesai, Ouster };

/// Looks at the first datagrams: a Velodyne data packet has a fixed size; anything else large
/// is taken as Ouster when a metadata JSON is at hand.
CaptureSensor sniffSensor(const fs::path& path, bool have_metadata, bool hesai_named) {
  if (hesai_named) return CaptureSensor::Hesai;
  PcapReader reader(path);
  UdpPacket packet;
  std::size_t seen = 0, largest = 0;
  std::uint16_t largest_port = 0;
  while (seen < 200 && reader.next(packet)) {
    ++seen;
    if (packet.payload.size() == kVelodyneDataPacketSize) return CaptureSensor::Velodyne;
    if (hesaiModelOfPacket(packet.payload)) return CaptureSensor::Hesai;
    if (packet.payload.size() > largest) largest = packet.payload.size(), largest_port = packet.destination_port;
  }
  if (seen == 0) fail(path.string(), "capture holds no UDP datagram");
  if (have_metadata || largest_port == 7502) return CaptureSensor::Ouster;
  fail(path.string(), "no Velodyne (1206 bytes) or Hesai data packet among the first " + std::to_string(seen) +
                          " datagrams (largest " + std::to_string(largest) + " bytes to port " +
                          std::to_string(largest_port) + "); an Ouster capture needs its metadata JSON "
                          "(--sensor-metadata)");
}

/// The Ouster metadata: --sensor-metadata, else the .json recorded with the capture (its name a
/// prefix of the capture's, as ouster-sdk pairs them).
fs::path metadataPath(const fs::path& capture, const ScanSourceOptions& options) {
  if (!options.sensor_metadata.empty()) return options.sensor_metadata;
  return findOusterMetadata(capture).value_or(fs::path());
}

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open the sensor metadata");
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class PcapScanSource final : public ScanSource {
 public:
  PcapScanSource(const fs::path& path, const ScanSourceOptions& options)
      : path_(path), options_(options), reader_(path) {
    const fs::path metadata = metadataPath(path, options);
    const CaptureSensor sensor = sniffSensor(path, !metadata.empty(), sensorIsHesai(options));
    if (sensor == CaptureSensor::Velodyne) {
      assembler_.emplace(LidarKind::VelodyneScan, makeVelodyneDecoderFor(options));
    } else if (sensor == CaptureSensor::Hesai) {
      assembler_.emplace(LidarKind::HesaiScan, makeHesaiDecoderFor(options));
    } else {
      if (metadata.empty())
        fail(path.string(), "an Ouster capture needs the sensor's metadata JSON: put it next to the capture "
                            "(named as a prefix of the capture's name) or give --sensor-metadata");
      assembler_.emplace(LidarKind::OusterPackets, makeOusterDecoderFor(readText(metadata), metadata.string()));
    }
    table_ = options.class_table ? *options.class_table : ClassTable::defaults();
  }

  std::optional<Scan> next() override {
    while (!exhausted_ && !scans_.ready()) {
      UdpPacket packet;
      if (reader_.next(packet)) {
        assembler_->addPacket(packet.payload, packet.time, path_.string() + ": datagram " +
                                                               std::to_string(packet.frame_index),
                              scans_.pending());
        scans_.imu().append(assembler_->takeImu());
        continue;
      }
      exhausted_ = true;
      for (const auto& line : assembler_->flush(path_.string(), scans_.pending())) notice(line);
      scans_.imu().append(assembler_->takeImu());
      for (const auto& line : reader_.loss().notices) notice(line);
      if (const std::string line = scans_.imu().notice(path_.string()); !line.empty()) notice(line);
    }
    if (scans_.empty()) return std::nullopt;
    return scans_.pop();
  }
  std::optional<std::size_t> size() const override { return std::nullopt; }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return path_.string() + " (" + assembler_->describe() + ")"; }

 private:
  void notice(const std::string& line) const {
    if (options_.notice) options_.notice(line.rfind(path_.string(), 0) == 0 ? line : path_.string() + ": " + line);
  }

  fs::path path_;
  ScanSourceOptions options_;
  PcapReader reader_;
  std::optional<ScanAssembler> assembler_;
  AssembledScans scans_;
  ClassTable table_;
  bool exhausted_ = false;
};

}  // namespace

std::unique_ptr<ScanSource> openPcapScanSource(const fs::path& path, const ScanSourceOptions& options) {
  return std::make_unique<PcapScanSource>(path, options);
}

}  // namespace hazmap::sources
