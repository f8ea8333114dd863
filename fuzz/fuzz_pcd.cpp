// libFuzzer target: PCD reader (ascii, binary, binary_compressed/LZF).
#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz.pcd");
  static const hazmap::ClassTable table = hazmap::ClassTable::semanticKitti();
  const std::string& path = file.set(data, size);
  try {
    hazmap::ReadStats stats;
    const auto cloud = hazmap::readPcd(path, table, &stats);
    hazmap::fuzz::checkCloud(cloud);
    if (cloud.size() + stats.dropped_non_finite != stats.points_in_file) std::abort();
  } catch (const hazmap::Error&) {
  }
  return 0;
}
