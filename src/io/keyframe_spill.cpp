#include "hazmap/io/keyframe_spill.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <optional>
#include <random>
#include <string>
#include <string_view>

#include "hazmap/core/error.hpp"
#include "hazmap/io/pcd.hpp"

namespace hazmap {

namespace fs = std::filesystem;

namespace {

constexpr std::string_view kPrefix = "hazmap-keyframes-";

// The process that made a spill folder "hazmap-keyframes-PID-N", if the name says.
std::optional<pid_t> ownerOf(const std::string& name) {
  if (!name.starts_with(kPrefix)) return std::nullopt;
  const std::string rest = name.substr(kPrefix.size());
  const auto dash = rest.find('-');
  if (dash == std::string::npos || dash == 0 || dash + 1 == rest.size()) return std::nullopt;
  const auto digits = [](std::string_view d) { return std::all_of(d.begin(), d.end(), [](char c) { return c >= '0' && c <= '9'; }); };
  if (!digits(std::string_view(rest).substr(0, dash)) || !digits(std::string_view(rest).substr(dash + 1)) || dash > 9)
    return std::nullopt;
  return static_cast<pid_t>(std::stol(rest.substr(0, dash)));
}

}  // namespace

// A process that ended without its destructors (kill -9, a power cut, a crash) leaves its folder
// behind, and a long mission's can hold gigabytes: the folders of processes that no longer exist
// go when the next spill starts. A folder whose process id was reused stays (it cannot be told).
void removeStaleKeyframeSpills(const fs::path& base) {
  std::error_code ec;
  for (fs::directory_iterator it(base, ec), end; !ec && it != end; it.increment(ec)) {
    const auto owner = ownerOf(it->path().filename().string());
    if (!owner || *owner == ::getpid()) continue;
    if (::kill(*owner, 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to ask about
    std::error_code ignored;
    fs::remove_all(it->path(), ignored);
  }
}

KeyframeSpill::KeyframeSpill() {
  std::error_code ec;
  const fs::path base = fs::temp_directory_path(ec);
  if (ec) fail("keyframe store", "no temporary folder: " + ec.message());
  removeStaleKeyframeSpills(base);
  std::random_device rd;
  const std::string prefix = std::string(kPrefix) + std::to_string(::getpid()) + "-";
  for (int attempt = 0; attempt < 100 && dir_.empty(); ++attempt) {
    const fs::path candidate = base / (prefix + std::to_string(rd()));
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
