#include "hazmap/io/keyframe_spill.hpp"

#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"

namespace hazmap {

namespace fs = std::filesystem;

KeyframeSpill::KeyframeSpill() {
  std::error_code ec;
  const fs::path base = fs::temp_directory_path(ec);
  if (ec) fail("keyframe store", "no temporary folder: " + ec.message());
  std::random_device rd;
  for (int attempt = 0; attempt < 100 && dir_.empty(); ++attempt) {
    const fs::path candidate = base / ("hazmap-keyframes-" + std::to_string(rd()));
    if (fs::create_directory(candidate, ec)) dir_ = candidate;
  }
  if (dir_.empty()) fail(base.string(), "cannot create a folder for the keyframes");
}

KeyframeSpill::~KeyframeSpill() {
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

fs::path KeyframeSpill::fileOf(std::size_t frame) const { return dir_ / (std::to_string(frame) + ".pcd"); }

// Binary PCD keeps every channel's bytes and hazmap's class ids (its writer marks them so).
void KeyframeSpill::store(std::size_t frame, const LabeledCloud& cloud) {
  writePcd(fileOf(frame), cloud, PcdEncoding::Binary);
}

LabeledCloud KeyframeSpill::load(std::size_t frame, const ClassTable& table) const {
  return readPcd(fileOf(frame), table);
}

}  // namespace hazmap
