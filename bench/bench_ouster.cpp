// Ouster packets → points on one core against the sensor's real time: the real OS-1-128 capture
// (1024×10, 128 beams, RNG15 profile: 64 packets a scan, 0.1 s each) and the OS-1-64 legacy one.
// realtime_x = seconds of sensor data decoded per second of one core (≥ 1 keeps up).
#include <filesystem>
#include <vector>

#include "bench_main.hpp"
#include "hazmap/sources/ouster.hpp"
#include "hazmap/sources/pcap_reader.hpp"

namespace {

using namespace hazmap;
namespace fs = std::filesystem;

struct Capture {
  OusterMetadata meta;
  std::vector<std::vector<std::uint8_t>> packets;  // lidar packets only
};

Capture load(const fs::path& json, const fs::path& pcap) {
  Capture c{readOusterMetadata(json), {}};
  PcapReader reader(pcap, PcapOptions{{7502}});
  UdpPacket p;
  while (reader.next(p)) c.packets.emplace_back(p.payload.begin(), p.payload.end());
  return c;
}

void decodeCapture(benchmark::State& state, const Capture& c) {
  OusterDecoder decoder(c.meta);  // the XYZ table is built once per sensor, outside the loop
  std::size_t points = 0;
  for (auto _ : state) {
    for (const auto& p : c.packets) {
      decoder.addPacket(p, 0.0, "bench");
      while (auto s = decoder.takeScan()) points += s->cloud.size();
    }
  }
  // Sensor time in the packets: columns sent / columns per second.
  const double seconds = static_cast<double>(c.packets.size() * c.meta.columns_per_packet) /
                         (c.meta.columns_per_frame * c.meta.scan_rate_hz);
  state.counters["realtime_x"] = benchmark::Counter(seconds * static_cast<double>(state.iterations()),
                                                    benchmark::Counter::kIsRate);
  state.counters["points_per_s"] = benchmark::Counter(static_cast<double>(points), benchmark::Counter::kIsRate);
  state.counters["packets_per_s"] = benchmark::Counter(
      static_cast<double>(c.packets.size() * state.iterations()), benchmark::Counter::kIsRate);
}

void BM_Ouster_Os1_128_Rng15(benchmark::State& state) {
  static const Capture c = load(fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10.json",
                                fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap");
  decodeCapture(state, c);
}
BENCHMARK(BM_Ouster_Os1_128_Rng15)->Unit(benchmark::kMillisecond);

void BM_Ouster_Os1_64_Legacy(benchmark::State& state) {
  static const Capture c = load(fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/ouster-os1-64/ouster_example.json",
                                fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/ouster-os1-64/ouster_example.pcap");
  decodeCapture(state, c);
}
BENCHMARK(BM_Ouster_Os1_64_Legacy)->Unit(benchmark::kMillisecond);

/// Reading the capture itself (libpcap + UDP parsing), for scale.
void BM_Pcap_ReadOs1_128(benchmark::State& state) {
  const fs::path pcap = fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/ouster-os1-128/OS-1-128_v2.3.0_1024x10_lb_n3.pcap";
  std::size_t bytes = 0;
  for (auto _ : state) {
    PcapReader reader(pcap);
    UdpPacket p;
    while (reader.next(p)) bytes += p.payload.size();
  }
  state.counters["payload_MB_per_s"] = benchmark::Counter(static_cast<double>(bytes) / 1e6, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_Pcap_ReadOs1_128)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
