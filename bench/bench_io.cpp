// Reader/writer throughput on the real shared data, with PCL's PCD I/O as the peer measured in
// the same run (items/s = points/s). Report ratios, not absolute times.
#include <benchmark/benchmark.h>

#include "bench_main.hpp"

#include <filesystem>
#include <string>

#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"

#ifdef HAZMAP_BENCH_HAVE_PCL
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#endif

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

const fs::path kData = HAZMAP_SHARED_DATA_DIR;
const fs::path kBin = kData / "kitti-semantic-sample/velodyne/000000.bin";
const fs::path kLabel = kData / "kitti-semantic-sample/labels/000000.label";
const fs::path kPcd = kData / "scan-pair/251370668.pcd";

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "hazmap-bench-io";
  fs::create_directories(dir);
  return dir / name;
}

/// The KITTI scan (124k points, intensity, labels) as a PCD in the given encoding.
const fs::path& kittiAsPcd(PcdEncoding enc) {
  static fs::path paths[3];
  fs::path& p = paths[static_cast<int>(enc)];
  if (p.empty()) {
    p = scratch("kitti_" + std::to_string(static_cast<int>(enc)) + ".pcd");
    writePcd(p, readKittiScan(kBin, kLabel, ClassTable::defaults()), enc);
  }
  return p;
}

void BM_Hazmap_ReadKittiBin(benchmark::State& state) {
  std::size_t n = 0;
  for (auto _ : state) {
    auto c = readKittiBin(kBin);
    n = c.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_Hazmap_ReadKittiBin)->Unit(benchmark::kMillisecond);

void BM_Hazmap_ReadKittiBinWithLabels(benchmark::State& state) {
  const ClassTable table = ClassTable::semanticKitti();
  std::size_t n = 0;
  for (auto _ : state) {
    auto c = readKittiScan(kBin, kLabel, table);
    n = c.size();
    benchmark::DoNotOptimize(c.classes.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_Hazmap_ReadKittiBinWithLabels)->Unit(benchmark::kMillisecond);

void BM_Hazmap_ReadPcd(benchmark::State& state) {
  const auto enc = static_cast<PcdEncoding>(state.range(0));
  const fs::path& path = enc == PcdEncoding::Binary && state.range(1) ? kPcd : kittiAsPcd(enc);
  std::size_t n = 0;
  for (auto _ : state) {
    auto c = readPcd(path);
    n = c.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.SetLabel(path.filename().string());
}
// Args: encoding (0 ascii, 1 binary, 2 binary_compressed), 1 = the real scan-pair file.
BENCHMARK(BM_Hazmap_ReadPcd)->Args({1, 1})->Args({1, 0})->Args({2, 0})->Args({0, 0})->Unit(benchmark::kMillisecond);

void BM_Hazmap_WritePcd(benchmark::State& state) {
  const auto enc = static_cast<PcdEncoding>(state.range(0));
  const auto cloud = readKittiScan(kBin, kLabel, ClassTable::defaults());
  const fs::path out = scratch("write.pcd");
  for (auto _ : state) writePcd(out, cloud, enc);
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud.size()));
}
BENCHMARK(BM_Hazmap_WritePcd)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_Hazmap_ReadPly(benchmark::State& state) {
  const fs::path path = scratch("kitti.ply");
  if (!fs::exists(path)) writePly(path, readKittiScan(kBin, kLabel, ClassTable::defaults()));
  std::size_t n = 0;
  for (auto _ : state) {
    auto c = readPly(path);
    n = c.size();
    benchmark::DoNotOptimize(c.points.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
}
BENCHMARK(BM_Hazmap_ReadPly)->Unit(benchmark::kMillisecond);

#ifdef HAZMAP_BENCH_HAVE_PCL
// PCL peer: the same files into pcl::PointCloud<pcl::PointXYZI> (PointXYZL for labelled).
void BM_Pcl_ReadPcd(benchmark::State& state) {
  const auto enc = static_cast<PcdEncoding>(state.range(0));
  const fs::path& path = enc == PcdEncoding::Binary && state.range(1) ? kPcd : kittiAsPcd(enc);
  std::size_t n = 0;
  for (auto _ : state) {
    pcl::PointCloud<pcl::PointXYZI> cloud;
    if (pcl::io::loadPCDFile(path.string(), cloud) != 0) state.SkipWithError("PCL failed to load");
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * n));
  state.SetLabel(path.filename().string());
}
BENCHMARK(BM_Pcl_ReadPcd)->Args({1, 1})->Args({1, 0})->Args({2, 0})->Args({0, 0})->Unit(benchmark::kMillisecond);

void BM_Pcl_WritePcd(benchmark::State& state) {
  pcl::PointCloud<pcl::PointXYZI> cloud;
  pcl::io::loadPCDFile(kittiAsPcd(PcdEncoding::Binary).string(), cloud);
  const std::string out = scratch("pcl_write.pcd").string();
  for (auto _ : state) {
    if (state.range(0) == 1)
      pcl::io::savePCDFileBinary(out, cloud);
    else
      pcl::io::savePCDFileBinaryCompressed(out, cloud);
  }
  state.SetItemsProcessed(static_cast<int64_t>(state.iterations() * cloud.size()));
}
BENCHMARK(BM_Pcl_WritePcd)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
#endif

}  // namespace

HAZMAP_BENCHMARK_MAIN()
