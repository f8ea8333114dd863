// The hand-written voxel hash tables against tsl::robin_map (Debian robin-map-dev, a maintained
// robin-hood open-addressing map) on the workloads they serve, keys from a real KITTI scan:
//  - LocalMap: the local map's VoxelKeyIndex (1 m voxels): insert every voxel, probe each voxel's
//    27 neighbours (what the normal search and the staleness checks do), drop half the voxels
//    and insert them again (what the map's bounding does every frame). The spatial index's
//    inline table (src/preprocess/spatial_index.cpp) has the same access pattern: first-seen ids,
//    then neighbour look-ups.
//  - GlobalMap: the global map's VoxelHashMap (0.1 m voxels): find-or-insert per point.
// Both sides hash with splitmix64Mix (core/hash.hpp), so the tables are compared, not the hashes.
#include <tsl/robin_map.h>

#include <cmath>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <vector>

#include "bench_main.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/hash.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/odometry/detail/voxel_key_index.hpp"
#include "map/voxel_hash.hpp"

namespace {

using namespace hazmap;

struct SplitmixHash {
  std::size_t operator()(std::uint64_t k) const { return static_cast<std::size_t>(splitmix64Mix(k)); }
};
using RobinIndex = tsl::robin_map<std::uint64_t, std::uint32_t, SplitmixHash>;

struct Voxel3 {
  std::int64_t x, y, z;
};

// The scan's voxel coordinates, one per point (duplicates kept: points share voxels).
std::vector<Voxel3> scanVoxels(double voxel) {
  static const LabeledCloud scan = [] {
    const std::filesystem::path dir = std::filesystem::path(HAZMAP_SHARED_DATA_DIR) / "kitti-semantic-sample";
    return readKittiScan(dir / "velodyne" / "000000.bin", {}, ClassTable::defaults());
  }();
  std::vector<Voxel3> out;
  out.reserve(scan.size());
  for (const Eigen::Vector3f& p : scan.points) {
    Voxel3 v;
    if (voxelCoordinate(p.x() / voxel, v.x) && voxelCoordinate(p.y() / voxel, v.y) &&
        voxelCoordinate(p.z() / voxel, v.z))
      out.push_back(v);
  }
  return out;
}

std::uint64_t keyOf(std::int64_t x, std::int64_t y, std::int64_t z) {
  std::uint64_t k = ~std::uint64_t{0};
  voxelKey(x, y, z, k);
  return k;
}

// Inserts every voxel (value = first-seen id), probes 27 neighbours of each voxel, erases every
// second voxel and inserts it again. `Table` adapts find / tryEmplace / erase.
template <class Table>
void localMapWorkload(benchmark::State& state) {
  const std::vector<Voxel3> voxels = scanVoxels(1.0);
  std::size_t found = 0;
  for (auto _ : state) {
    Table t;
    std::vector<Voxel3> distinct;
    for (const Voxel3& v : voxels)
      if (t.tryEmplace(keyOf(v.x, v.y, v.z), static_cast<std::uint32_t>(distinct.size()))) distinct.push_back(v);
    for (const Voxel3& v : distinct)
      for (int dx = -1; dx <= 1; ++dx)
        for (int dy = -1; dy <= 1; ++dy)
          for (int dz = -1; dz <= 1; ++dz) found += t.find(keyOf(v.x + dx, v.y + dy, v.z + dz)) != nullptr;
    for (std::size_t i = 0; i < distinct.size(); i += 2) t.erase(keyOf(distinct[i].x, distinct[i].y, distinct[i].z));
    for (std::size_t i = 0; i < distinct.size(); i += 2)
      t.tryEmplace(keyOf(distinct[i].x, distinct[i].y, distinct[i].z), static_cast<std::uint32_t>(i));
    benchmark::DoNotOptimize(found);
  }
  state.counters["points"] = static_cast<double>(voxels.size());
}

struct HandWrittenIndex {
  detail::VoxelKeyIndex index;
  bool tryEmplace(std::uint64_t k, std::uint32_t v) { return index.tryEmplace(k, v).second; }
  const std::uint32_t* find(std::uint64_t k) const { return index.find(k); }
  void erase(std::uint64_t k) { index.erase(k); }
};
struct RobinAsIndex {
  RobinIndex index;
  bool tryEmplace(std::uint64_t k, std::uint32_t v) { return index.try_emplace(k, v).second; }
  const std::uint32_t* find(std::uint64_t k) const {
    const auto it = index.find(k);
    return it == index.end() ? nullptr : &it->second;
  }
  void erase(std::uint64_t k) { index.erase(k); }
};

// Find-or-insert per point, values kept densely in insertion order as the global map needs them.
struct Cell {
  std::uint32_t count = 0;
  float sum = 0.0f;
};

void BM_HashTable_LocalMap_HandWritten(benchmark::State& state) { localMapWorkload<HandWrittenIndex>(state); }
void BM_HashTable_LocalMap_RobinMap(benchmark::State& state) { localMapWorkload<RobinAsIndex>(state); }

void BM_HashTable_GlobalMap_HandWritten(benchmark::State& state) {
  const std::vector<Voxel3> voxels = scanVoxels(0.1);
  for (auto _ : state) {
    detail::VoxelHashMap<Cell> cells;
    for (const Voxel3& v : voxels) {
      Cell& c = cells[keyOf(v.x, v.y, v.z)];
      ++c.count;
      c.sum += 1.0f;
    }
    benchmark::DoNotOptimize(cells.size());
  }
}

void BM_HashTable_GlobalMap_RobinMap(benchmark::State& state) {
  const std::vector<Voxel3> voxels = scanVoxels(0.1);
  for (auto _ : state) {
    RobinIndex index;
    std::deque<std::uint64_t> keys;
    std::deque<Cell> values;
    for (const Voxel3& v : voxels) {
      const std::uint64_t k = keyOf(v.x, v.y, v.z);
      const auto [it, inserted] = index.try_emplace(k, static_cast<std::uint32_t>(values.size()));
      if (inserted) {
        keys.push_back(k);
        values.emplace_back();
      }
      Cell& c = values[it->second];
      ++c.count;
      c.sum += 1.0f;
    }
    benchmark::DoNotOptimize(values.size());
  }
}

BENCHMARK(BM_HashTable_LocalMap_HandWritten)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_HashTable_LocalMap_RobinMap)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_HashTable_GlobalMap_HandWritten)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_HashTable_GlobalMap_RobinMap)->Unit(benchmark::kMillisecond);

}  // namespace

HAZMAP_BENCHMARK_MAIN();
