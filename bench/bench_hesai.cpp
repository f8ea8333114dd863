// Hesai decoding speed on one core, in multiples of real time: the real Pandar40P, Pandar64,
// PandarXT32 (dual return) and PandarQT128 (last+strongest) packets of ../shared/data decoded into
// scans. Real time is the sensor's own packet rate (from the packets' stamps), so a factor of 50
// means one core decodes 50 sensors' worth of packets. The peer in the same run is the Velodyne
// decoder on the VLP-16 dual-return bag (points/s of both compare the decoders' cost per point).
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/hesai.hpp"
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

/// Every packet of the recording's bag (rosbag2 folder; the one sub-folder for the Hesai ones).
Recording load(const fs::path& folder, bool hesai) {
  fs::path bag = folder;
  if (hesai)
    for (const auto& e : fs::directory_iterator(folder))
      if (e.is_directory()) bag = e.path();
  Recording r;
  auto reader = openBag(bag);
  BagMessage m;
  while (reader->next(m)) {
    const auto msg = hesai ? decodePandarScan(m.data, m.topic->serialization, bag.string())
                           : decodeVelodyneScan(m.data, m.topic->serialization, bag.string());
    for (const auto& p : msg.packets) {
      r.packets.push_back(p.data);
      r.stamps.push_back(p.stamp);
    }
  }
  r.packets_per_second = static_cast<double>(r.packets.size() - 1) / (r.stamps.back() - r.stamps.front());
  return r;
}

template <typename Make>
void decodeRecording(benchmark::State& state, const Recording& rec, Make make) {
  std::size_t points = 0, packets = 0;
  for (auto _ : state) {
    auto decoder = make();
    for (std::size_t i = 0; i < rec.packets.size(); ++i) {
      decoder->addPacket(rec.packets[i], rec.stamps[i], "bench");
      while (auto s = decoder->takeScan()) points += s->cloud.size();
    }
    while (auto s = decoder->flush()) points += s->cloud.size();
    packets += rec.packets.size();
  }
  state.SetItemsProcessed(static_cast<int64_t>(points));
  state.counters["packets_per_s"] = benchmark::Counter(static_cast<double>(packets), benchmark::Counter::kIsRate);
  state.counters["packets_per_s_sensor"] = rec.packets_per_second;
  state.counters["x_realtime"] =
      benchmark::Counter(static_cast<double>(packets) / rec.packets_per_second, benchmark::Counter::kIsRate);
}

void hesai(benchmark::State& state, const std::string& folder) {
  static std::map<std::string, Recording> cache;
  if (!cache.count(folder)) cache[folder] = load(kData / "sensors" / folder, true);
  decodeRecording(state, cache[folder], [] { return makeHesaiDecoder({}); });
}

void BM_Hesai_Pandar40PDual(benchmark::State& state) { hesai(state, "hesai-pandar40p"); }
void BM_Hesai_Pandar64Dual(benchmark::State& state) { hesai(state, "hesai-pandar64"); }
void BM_Hesai_PandarXT32Dual(benchmark::State& state) { hesai(state, "hesai-xt32"); }
void BM_Hesai_PandarQT128LastStrongest(benchmark::State& state) { hesai(state, "hesai-qt128"); }
BENCHMARK(BM_Hesai_Pandar40PDual)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Hesai_Pandar64Dual)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Hesai_PandarXT32Dual)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Hesai_PandarQT128LastStrongest)->Unit(benchmark::kMillisecond);

void BM_Peer_VelodyneVlp16Dual(benchmark::State& state) {
  static const Recording rec = load(kData / "sensors/velodyne-vlp16", false);
  decodeRecording(state, rec, [] { return makeVelodyneDecoder({}); });
}
BENCHMARK(BM_Peer_VelodyneVlp16Dual)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN();
