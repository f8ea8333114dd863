// Velodyne decoding speed on one core, in multiples of real time: the real VLP-16 packets
// (nebula's dual-return bag: 1508 packets/s from the sensor; the strongest-return capture:
// 754 packets/s) decoded into scans. Real time is the sensor's own packet rate, so a factor
// of 50 means one core decodes 50 sensors' worth of packets.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <filesystem>
#include <vector>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "hazmap/sources/ros_messages.hpp"
#include "hazmap/sources/velodyne.hpp"

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

const fs::path kData = HAZMAP_SHARED_DATA_DIR;

struct Recording {
  std::vector<std::vector<std::uint8_t>> packets;
  std::vector<double> stamps;
  double packets_per_second = 0;  ///< the sensor's rate, from the recording's own time span
};

Recording fromBag() {
  Recording r;
  auto bag = openBag(kData / "sensors/velodyne-vlp16");
  BagMessage m;
  while (bag->next(m))
    for (auto& p : decodeVelodyneScan(m.data, m.topic->serialization, "vlp16").packets) {
      r.packets.push_back(p.data);
      r.stamps.push_back(p.stamp);
    }
  r.packets_per_second = (r.packets.size() - 1) / (r.stamps.back() - r.stamps.front());
  return r;
}

Recording fromCapture() {
  Recording r;
  PcapReader reader(kData / "sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap");
  UdpPacket u;
  while (reader.next(u))
    if (u.payload.size() == kVelodyneDataPacketSize) {
      r.packets.emplace_back(u.payload.begin(), u.payload.end());
      r.stamps.push_back(u.time);
    }
  r.packets_per_second = (r.packets.size() - 1) / (r.stamps.back() - r.stamps.front());
  return r;
}

void decodeRecording(benchmark::State& state, const Recording& rec) {
  std::size_t points = 0, packets = 0;
  for (auto _ : state) {
    auto decoder = makeVelodyneDecoder({});
    for (std::size_t i = 0; i < rec.packets.size(); ++i) {
      decoder->addPacket(rec.packets[i], rec.stamps[i], "bench");
      while (auto s = decoder->takeScan()) points += s->cloud.size();
    }
    if (auto s = decoder->flush()) points += s->cloud.size();
    packets += rec.packets.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(points));
  state.counters["packets_per_s_sensor"] = rec.packets_per_second;
  state.counters["x_realtime"] = benchmark::Counter(
      static_cast<double>(packets) / rec.packets_per_second, benchmark::Counter::kIsRate);
}

void BM_Velodyne_Vlp16DualReturnBag(benchmark::State& state) {
  static const Recording rec = fromBag();
  decodeRecording(state, rec);
}
BENCHMARK(BM_Velodyne_Vlp16DualReturnBag)->Unit(benchmark::kMillisecond);

void BM_Velodyne_Vlp16StrongestCapture(benchmark::State& state) {
  static const Recording rec = fromCapture();
  decodeRecording(state, rec);
}
BENCHMARK(BM_Velodyne_Vlp16StrongestCapture)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN();
