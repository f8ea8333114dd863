// libFuzzer target: rosbag2 folders. Input: one mode byte, then the bytes. Mode 0: the bytes
// are metadata.yaml of a folder holding a copy of a small valid .db3 (named run_0.db3); mode 1:
// the bytes are the .db3 itself (sqlite3 file from bytes), opened as a one-file rosbag2.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "fuzz_bag.hpp"
#include "sources/bag_readers.hpp"

namespace fs = std::filesystem;

namespace {

fs::path scratch() {
  static const fs::path dir = fs::temp_directory_path() / ("hazmap-fuzz-rosbag2-" + std::to_string(::getpid()));
  static bool made = [] {
    fs::create_directories(dir);
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(dir, ec);
    });
    return true;
  }();
  (void)made;
  return dir;
}

void put(const fs::path& p, const std::uint8_t* data, std::size_t size) {
  std::ofstream(p, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const int mode = data[0] % 2;
  const fs::path dir = scratch();
  try {
    if (mode == 0) {
      if (!fs::exists(dir / "run_0.db3")) {
        const char* seed = std::getenv("HAZMAP_FUZZ_DB3");  // a small valid .db3 to point at
        if (seed) fs::copy_file(seed, dir / "run_0.db3", fs::copy_options::overwrite_existing);
      }
      put(dir / "metadata.yaml", data + 1, size - 1);
      auto reader = hazmap::sources::openRosbag2(dir);
      hazmap::fuzz::drain(*reader);
    } else {
      put(dir / "bytes.db3", data + 1, size - 1);
      auto reader = hazmap::sources::openDb3(dir / "bytes.db3");
      hazmap::fuzz::drain(*reader);
    }
  } catch (const hazmap::Error&) {
  }
  return 0;
}
