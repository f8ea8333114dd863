// libFuzzer target: KITTI .bin scans and SemanticKITTI .label files.
// Input: one mode byte, then the bytes. Mode 0: a .bin alone; mode 1: a .bin and a .label
// split after 16·n bytes with n = rest/20 (so a valid pair of n points is a valid input);
// mode 2: a .label alone.
#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/kitti.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile bin("fuzz.bin"), label("fuzz.label");
  static const hazmap::ClassTable table = hazmap::ClassTable::semanticKitti();
  if (size < 1) return 0;
  const int mode = data[0] % 3;
  ++data;
  --size;
  try {
    if (mode == 0) {
      hazmap::ReadStats stats;
      const auto cloud = hazmap::readKittiBin(bin.set(data, size), &stats);
      hazmap::fuzz::checkCloud(cloud);
      if (cloud.size() + stats.dropped_non_finite != stats.points_in_file) std::abort();
    } else if (mode == 1) {
      const std::size_t split = 16 * (size / 20);
      const std::string& bin_path = bin.set(data, split);
      const std::string& label_path = label.set(data + split, size - split);
      hazmap::ReadStats stats;
      const auto cloud = hazmap::readKittiScan(bin_path, label_path, table, &stats);
      hazmap::fuzz::checkCloud(cloud);
      for (auto c : cloud.classes)
        if (c > 3) std::abort();  // the semantic-kitti table only maps to classes 0..3
    } else {
      const auto labels = hazmap::readSemanticKittiLabels(label.set(data, size));
      if (labels.size() * 4 != size) std::abort();
    }
  } catch (const hazmap::Error&) {
  }
  return 0;
}
