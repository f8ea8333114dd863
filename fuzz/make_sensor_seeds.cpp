// Seed corpus for fuzz_pcap and fuzz_ouster from the real captures in the shared data: the
// first records of the VLP-16, OS-1-64 and OS-1-128 captures (and the OS-1-64's first packet
// sent as IPv4 fragments), the OS-1-128 metadata, and packets of each of fuzz_ouster's sensors.
// Usage: hazmap_fuzz_sensor_seeds SHARED_DATA_DIR OUT_DIR
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <vector>

#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "ouster_sensors.hpp"
#include "sources/ouster_packet.hpp"

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

namespace {

void write(const fs::path& path, const Bytes& b) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}

Bytes head(const fs::path& path, std::size_t records) {  // a classic pcap's header and first records
  std::ifstream in(path, std::ios::binary);
  Bytes b(24);
  in.read(reinterpret_cast<char*>(b.data()), 24);
  for (std::size_t i = 0; i < records; ++i) {
    Bytes rec(16);
    if (!in.read(reinterpret_cast<char*>(rec.data()), 16)) break;
    std::uint32_t caplen;
    std::memcpy(&caplen, &rec[8], 4);
    rec.resize(16 + caplen);
    in.read(reinterpret_cast<char*>(rec.data() + 16), caplen);
    b.insert(b.end(), rec.begin(), rec.end());
  }
  return b;
}

/// The first record of a pcap (Ethernet + IPv4 + UDP) re-sent as 1,500-byte IPv4 fragments.
Bytes fragmented(const Bytes& one) {
  Bytes out(one.begin(), one.begin() + 24);
  const Bytes frame(one.begin() + 40, one.end());
  const Bytes udp(frame.begin() + 34, frame.end());
  for (std::size_t off = 0; off < udp.size(); off += 1480) {
    const std::size_t n = std::min<std::size_t>(1480, udp.size() - off);
    Bytes f(frame.begin(), frame.begin() + 34);
    const std::size_t total = 20 + n;
    f[16] = static_cast<std::uint8_t>(total >> 8), f[17] = total & 0xff;
    const std::size_t flags = (off + n < udp.size() ? 0x2000 : 0) | off / 8;
    f[20] = static_cast<std::uint8_t>(flags >> 8), f[21] = flags & 0xff;
    f.insert(f.end(), udp.begin() + static_cast<long>(off), udp.begin() + static_cast<long>(off + n));
    Bytes rec(one.begin() + 24, one.begin() + 40);
    const auto len = static_cast<std::uint32_t>(f.size());
    std::memcpy(&rec[8], &len, 4), std::memcpy(&rec[12], &len, 4);
    out.insert(out.end(), rec.begin(), rec.end());
    out.insert(out.end(), f.begin(), f.end());
  }
  return out;
}

/// Packets of one frame of a small sensor, valid columns, ranges of a few metres.
Bytes frame(const hazmap::OusterMetadata& m, std::size_t packets) {
  const hazmap::ouster_detail::PacketLayout layout(m);
  Bytes out;
  for (std::size_t p = 0; p < packets; ++p) {
    Bytes b(layout.packet_size, 0);
    if (m.profile != hazmap::OusterProfile::Legacy) {
      b[0] = 1, b[2] = 5;
      std::memcpy(&b[4], &m.initialization_id, 3);
      const std::uint64_t sn = m.serial.empty() ? 0 : std::stoull(m.serial);
      std::memcpy(&b[7], &sn, 5);
    }
    for (std::size_t c = 0; c < layout.columns; ++c) {
      std::uint8_t* col = &b[layout.packet_header + c * layout.column_size];
      const std::uint64_t ts = 1'000'000'000ull + (p * layout.columns + c) * 195'312ull;
      const auto m_id = static_cast<std::uint16_t>(p * layout.columns + c);
      std::memcpy(col, &ts, 8), std::memcpy(col + 8, &m_id, 2);
      if (m.profile == hazmap::OusterProfile::Legacy) {
        col[10] = 5;
        std::memset(col + layout.column_size - 4, 0xff, 4);
      } else {
        col[10] = 1;
      }
      for (std::size_t r = 0; r < layout.pixels; ++r) {
        const std::uint32_t range = m.profile == hazmap::OusterProfile::Rng15Rfl8Nir8 ? 500 + r : 4000 + 100 * r;
        std::memcpy(col + layout.column_header + r * layout.pixel_size, &range, m.profile == hazmap::OusterProfile::Rng15Rfl8Nir8 ? 2 : 4);
      }
    }
    out.insert(out.end(), b.begin(), b.end());
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: hazmap_fuzz_sensor_seeds SHARED_DATA_DIR OUT_DIR\n";
    return 2;
  }
  const fs::path data = fs::path(argv[1]) / "sensors", out = argv[2];
  fs::create_directories(out / "pcap");
  fs::create_directories(out / "ouster");
  write(out / "pcap/vlp16.pcap", head(data / "velodyne-vlp16-pcap/velodyne_vlp16.pcap", 6));
  const Bytes os64 = head(data / "ouster-os1-64/ouster_example.pcap", 1);
  write(out / "pcap/os1-64.pcap", os64);
  write(out / "pcap/os1-64-fragments.pcap", fragmented(os64));
  write(out / "pcap/os1-128.pcap", head(data / "ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap", 5));
  const Bytes os128 = head(data / "ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap", 1000);

  std::ifstream json(data / "ouster-os1-128/OS-1-128_v2.3.0_1024x10.json");
  std::string text((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  Bytes meta(1, 0);
  meta.insert(meta.end(), text.begin(), text.end());
  write(out / "ouster/os1-128-metadata", meta);
  // fuzz_imu: the capture's real IMU packets (odd first byte) and an imu.txt (even).
  fs::create_directories(out / "imu");
  Bytes imu_packets(1, 1);
  for (std::size_t at = 24; at + 16 <= os128.size();) {
    std::uint32_t caplen;
    std::memcpy(&caplen, &os128[at + 8], 4);
    const std::size_t payload = at + 16 + 42;  // Ethernet 14 + IPv4 20 + UDP 8
    if (caplen == 42 + hazmap::kOusterImuPacketSize && payload + hazmap::kOusterImuPacketSize <= os128.size())
      imu_packets.insert(imu_packets.end(), os128.begin() + static_cast<long>(payload),
                         os128.begin() + static_cast<long>(payload + hazmap::kOusterImuPacketSize));
    at += 16 + caplen;
  }
  write(out / "imu/os1-128-packets", imu_packets);
  const std::string imu_txt = "# time wx wy wz ax ay az\n0 0.01 -0.02 0.003 0.1 0.2 9.8\n0.005 0.011 -0.02 0.003 0.1 0.2 9.81\n";
  Bytes imu_file{0};
  imu_file.insert(imu_file.end(), imu_txt.begin(), imu_txt.end());
  write(out / "imu/imu-txt", imu_file);
  // ... and --imu-rotation texts (first byte 'R').
  for (const auto& [name, text] : {std::pair<const char*, std::string>{"rotation-rpy", "R10,-20,90"},
                                   {"rotation-quaternion", "R0.7071067811865476 0 0 0.7071067811865476"},
                                   {"rotation-4x4", "R0 -1 0 0.1 1 0 0 -0.2 0 0 1 0.05 0 0 0 1"}})
    write(out / "imu" / name, Bytes(text.begin(), text.end()));
  std::uint8_t mode = 1;
  for (const auto& m : hazmap::fuzz::fuzzOusterSensors()) {
    Bytes seed{mode};
    const Bytes packets = frame(m, 3);
    seed.insert(seed.end(), packets.begin(), packets.end());
    write(out / ("ouster/sensor-" + std::to_string(mode++)), seed);
  }
  return 0;
}
