// Bag reading throughput: PointCloud2 messages read from an MCAP (zstd, lz4, uncompressed
// chunks) in bytes/s of decompressed message payload, then decoded and converted to clouds.
// The bag is written once by hazmap's MCAP writer from the real 64,000-point CDR cloud
// (pointcloud2-cdr/, 1.66 MB per message). Peer in the same run: zstd decompressing the same
// payload in one call (what any reader must pay at least).
#include <benchmark/benchmark.h>
#include <zstd.h>

#include "bench_main.hpp"

#include <filesystem>
#include <fstream>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/mcap_writer.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

constexpr int kMessages = 60;

const std::vector<std::uint8_t>& realCloud() {
  static const std::vector<std::uint8_t> bytes = [] {
    std::ifstream in(fs::path(HAZMAP_SHARED_DATA_DIR) / "sensors/pointcloud2-cdr/pointcloud2_64000_points.cdr", std::ios::binary);
    return std::vector<std::uint8_t>{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }();
  return bytes;
}

/// kMessages copies of the real cloud in one MCAP per compression (written once per run).
const fs::path& bag(McapCompression compression) {
  static fs::path paths[3];
  fs::path& p = paths[static_cast<int>(compression)];
  if (p.empty()) {
    const fs::path dir = fs::temp_directory_path() / "hazmap-bench-sources";
    fs::create_directories(dir);
    p = dir / ("clouds" + std::to_string(static_cast<int>(compression)) + ".mcap");
    McapWriterOptions options;
    options.compression = compression;
    McapWriter writer(p, options);
    const auto channel = writer.addRosChannel("/points_raw", "sensor_msgs/msg/PointCloud2");
    for (int i = 0; i < kMessages; ++i) writer.write(channel, 1'000'000'000LL * (i + 1), realCloud());
    writer.close();
  }
  return p;
}

template <class PerMessage>
void readBag(benchmark::State& state, McapCompression compression, PerMessage per_message) {
  const fs::path& path = bag(compression);
  std::uint64_t bytes = 0, items = 0;
  for (auto _ : state) {
    auto reader = openBag(path);
    BagMessage m;
    while (reader->next(m)) {
      bytes += m.data.size();
      items += per_message(m);
    }
    if (!reader->loss().notices.empty()) state.SkipWithError(reader->loss().notices.front().c_str());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(bytes));
  state.SetItemsProcessed(static_cast<std::int64_t>(items));
}

void BM_McapRead(benchmark::State& state) {
  readBag(state, static_cast<McapCompression>(state.range(0)), [](const BagMessage& m) {
    benchmark::DoNotOptimize(m.data.data());
    return std::uint64_t{1};
  });
}
BENCHMARK(BM_McapRead)->Arg(0)->Arg(1)->Arg(2)->ArgNames({"zstd0_lz4_1_none2"})->Unit(benchmark::kMillisecond);

void BM_McapReadDecodePointCloud2(benchmark::State& state) {
  readBag(state, McapCompression::Zstd, [](const BagMessage& m) {
    const auto msg = decodePointCloud2(m.data, m.topic->serialization, "bench");
    return std::uint64_t{msg.width} * msg.height;
  });
}
BENCHMARK(BM_McapReadDecodePointCloud2)->Unit(benchmark::kMillisecond);

void BM_McapReadToCloud(benchmark::State& state) {
  readBag(state, McapCompression::Zstd, [](const BagMessage& m) {
    return std::uint64_t{pointCloud2ToCloud(decodePointCloud2(m.data, m.topic->serialization, "bench"), "bench").size()};
  });
}
BENCHMARK(BM_McapReadToCloud)->Unit(benchmark::kMillisecond);

/// Peer: zstd alone on the same payload (kMessages clouds in one frame, decompressed at once).
void BM_PeerZstdDecompress(benchmark::State& state) {
  std::vector<std::uint8_t> payload;
  for (int i = 0; i < kMessages; ++i) payload.insert(payload.end(), realCloud().begin(), realCloud().end());
  std::vector<std::uint8_t> compressed(ZSTD_compressBound(payload.size()));
  compressed.resize(ZSTD_compress(compressed.data(), compressed.size(), payload.data(), payload.size(), 3));
  std::vector<std::uint8_t> out(payload.size());
  for (auto _ : state) {
    benchmark::DoNotOptimize(ZSTD_decompress(out.data(), out.size(), compressed.data(), compressed.size()));
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * payload.size()));
  state.counters["ratio"] = static_cast<double>(payload.size()) / static_cast<double>(compressed.size());
}
BENCHMARK(BM_PeerZstdDecompress)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
