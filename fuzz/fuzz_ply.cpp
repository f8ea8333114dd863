// libFuzzer target: PLY reader, as a cloud and as a triangle mesh.
#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz.ply");
  static const hazmap::ClassTable table = hazmap::ClassTable::semanticKitti();
  const std::string& path = file.set(data, size);
  try {
    hazmap::ReadStats stats;
    const auto cloud = hazmap::readPly(path, table, &stats);
    hazmap::fuzz::checkCloud(cloud);
    if (cloud.size() + stats.dropped_non_finite != stats.points_in_file) std::abort();
  } catch (const hazmap::Error&) {
  }
  try {
    const auto mesh = hazmap::readPlyMesh(path);
    const auto nv = static_cast<int>(mesh.vertices.size());
    for (const auto& t : mesh.triangles)
      for (int k = 0; k < 3; ++k)
        if (t[k] < 0 || t[k] >= nv) std::abort();
    if (!mesh.triangle_classes.empty() && mesh.triangle_classes.size() != mesh.triangles.size()) std::abort();
  } catch (const hazmap::Error&) {
  }
  return 0;
}
