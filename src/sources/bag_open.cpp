// openBag()/isBag(): which container a path is, decided by its content (magic bytes,
// metadata.yaml), not only by its name.
#include <algorithm>
#include <cstring>
#include <fstream>

#include "bag_readers.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {
namespace fs = std::filesystem;
namespace {

enum class BagKind { None, Rosbag2, Mcap, Ros1 };

std::string fileStart(const fs::path& p, std::size_t n) {
  std::ifstream in(p, std::ios::binary);
  std::string s(n, '\0');
  in.read(s.data(), static_cast<std::streamsize>(n));
  s.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
  return s;
}

BagKind kindOf(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    if (fs::is_regular_file(path / "metadata.yaml", ec)) {
      return fileStart(path / "metadata.yaml", 4096).find("rosbag2_bagfile_information") != std::string::npos
                 ? BagKind::Rosbag2 : BagKind::None;
    }
    for (const auto& e : fs::directory_iterator(path, ec)) {
      const auto ext = e.path().extension();
      if (e.is_regular_file() && (ext == ".db3" || ext == ".mcap")) return BagKind::Rosbag2;
    }
    return BagKind::None;
  }
  if (!fs::is_regular_file(path, ec)) return BagKind::None;
  if (path.filename() == "metadata.yaml") return kindOf(path.parent_path());
  const std::string head = fileStart(path, 16);
  if (head.size() >= 8 && std::memcmp(head.data(), sources::kMcapMagic, 8) == 0) return BagKind::Mcap;
  if (head.rfind(sources::kRos1Magic, 0) == 0) return BagKind::Ros1;
  if (head.size() == 16 && std::memcmp(head.data(), "SQLite format 3\0", 16) == 0) return BagKind::Rosbag2;
  return BagKind::None;
}

}  // namespace

bool isBag(const fs::path& path) { return kindOf(path) != BagKind::None; }

std::unique_ptr<MessageReader> openBag(const fs::path& path) {
  switch (kindOf(path)) {
    case BagKind::Rosbag2: return sources::openRosbag2(path);
    case BagKind::Mcap: return sources::openMcap(path);
    case BagKind::Ros1: return sources::openRos1Bag(path);
    case BagKind::None: break;
  }
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path.string(), "no such file or folder");
  fail(path.string(), "not a bag (expected an .mcap file, a ROS 1 .bag, or a rosbag2 folder with metadata.yaml)");
}

namespace sources {

std::string ros2TypeName(const std::string& type) {
  const auto slash = type.find('/');
  if (slash == std::string::npos || type.find('/', slash + 1) != std::string::npos) return type;
  return type.substr(0, slash) + "/msg/" + type.substr(slash + 1);
}

Serialization serializationFromName(const std::string& name) {
  if (name.empty() || name == "cdr") return Serialization::Cdr;
  if (name == "ros1") return Serialization::Ros1;
  return Serialization::Other;
}

}  // namespace sources
}  // namespace hazmap
