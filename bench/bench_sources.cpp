// Bag reading throughput: PointCloud2 messages read from an MCAP (zstd, lz4, uncompressed
// chunks) in bytes/s of decompressed message payload, then decoded and converted to clouds.
// The bag is written once by hazmap's MCAP writer from the real 64,000-point CDR cloud
// (pointcloud2-cdr/, 1.66 MB per message). Peer in the same run: zstd decompressing the same
// payload in one call (what any reader must pay at least).
#include <benchmark/benchmark.h>
#include <zstd.h>

#include "bench_main.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>

#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/mcap_writer.hpp"
#include "hazmap/sources/ros_encode.hpp"
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

/// The real cloud moved 1 cm per message along x, so no two messages compress into each other.
std::vector<std::uint8_t> movedCloud(int i) {
  PointCloud2 msg = decodePointCloud2(realCloud(), Serialization::Cdr, "bench");
  for (std::size_t p = 0; p + 4 <= msg.data.size(); p += msg.point_step) {  // x: float32 at offset 0
    float x;
    std::memcpy(&x, msg.data.data() + p, 4);
    x += 0.01f * static_cast<float>(i);
    std::memcpy(msg.data.data() + p, &x, 4);
  }
  return encodePointCloud2(msg);
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
    for (int i = 0; i < kMessages; ++i) writer.write(channel, 1'000'000'000LL * (i + 1), movedCloud(i));
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

void BM_McapRead(benchmark::State& state, McapCompression compression) {
  readBag(state, compression, [](const BagMessage& m) {
    benchmark::DoNotOptimize(m.data.data());
    return std::uint64_t{1};
  });
}
BENCHMARK_CAPTURE(BM_McapRead, zstd, McapCompression::Zstd)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_McapRead, lz4, McapCompression::Lz4)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_McapRead, uncompressed, McapCompression::None)->Unit(benchmark::kMillisecond);

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

/// Peer: zstd alone on the same payload, compressed in 4 MiB frames like the bag's chunks.
void BM_PeerZstdDecompress(benchmark::State& state) {
  std::vector<std::uint8_t> payload;
  for (int i = 0; i < kMessages; ++i) {
    const auto cloud = movedCloud(i);
    payload.insert(payload.end(), cloud.begin(), cloud.end());
  }
  constexpr std::size_t kFrame = 4u << 20;
  std::vector<std::vector<std::uint8_t>> frames;
  std::size_t compressed_bytes = 0;
  for (std::size_t at = 0; at < payload.size(); at += kFrame) {
    const std::size_t n = std::min(kFrame, payload.size() - at);
    std::vector<std::uint8_t> f(ZSTD_compressBound(n));
    f.resize(ZSTD_compress(f.data(), f.size(), payload.data() + at, n, 3));
    compressed_bytes += f.size();
    frames.push_back(std::move(f));
  }
  std::vector<std::uint8_t> out(kFrame);
  for (auto _ : state) {
    for (const auto& f : frames) benchmark::DoNotOptimize(ZSTD_decompress(out.data(), out.size(), f.data(), f.size()));
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * payload.size()));
  state.counters["ratio"] = static_cast<double>(payload.size()) / static_cast<double>(compressed_bytes);
}
BENCHMARK(BM_PeerZstdDecompress)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN()
