#include "hazmap/io/cloud_file.hpp"

#include <system_error>

#include "hazmap/core/error.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

/// SemanticKITTI layout: velodyne/NNNNNN.bin ↔ labels/NNNNNN.label; also NNNNNN.label beside.
std::optional<std::filesystem::path> findLabelFor(const std::filesystem::path& bin) {
  std::error_code ec;
  auto beside = bin;
  beside.replace_extension(".label");
  if (std::filesystem::is_regular_file(beside, ec)) return beside;
  const auto sibling = bin.parent_path().parent_path() / "labels" / beside.filename();
  if (!bin.parent_path().empty() && std::filesystem::is_regular_file(sibling, ec)) return sibling;
  return std::nullopt;
}

[[noreturn]] void unknownFormat(const std::filesystem::path& path) {
  fail(path.string(), "unknown cloud format '" + path.extension().string() + "' (expected .bin, .pcd or .ply)");
}

}  // namespace

LabeledCloud readCloud(const std::filesystem::path& path, const ClassTable& table, ReadStats* stats,
                       const std::optional<std::filesystem::path>& label) {
  const std::string ext = io_detail::extensionOf(path);
  if (ext == ".bin") return readKittiScan(path, label ? label : findLabelFor(path), table, stats);
  if (label) fail(label->string(), "a separate label file only goes with a .bin scan");
  if (ext == ".pcd") return readPcd(path, table, stats);
  if (ext == ".ply") return readPly(path, table, stats);
  unknownFormat(path);
}

void writeCloud(const std::filesystem::path& path, const LabeledCloud& cloud, const ClassTable& table) {
  const std::string ext = io_detail::extensionOf(path);
  if (ext == ".bin") {
    cloud.checkConsistent(path.string());
    bool labelled = false;
    for (ClassId c : cloud.classes) labelled = labelled || c != 0;
    writeKittiBin(path, cloud);
    if (labelled) {
      auto label = path;
      label.replace_extension(".label");
      writeSemanticKittiLabels(label, cloud);
    }
    return;
  }
  if (ext == ".pcd") return writePcd(path, cloud, PcdEncoding::Binary);
  if (ext == ".ply") {
    cloud.checkConsistent(path.string());
    PlyWriteOptions options;
    options.colors.reserve(cloud.size());
    for (ClassId c : cloud.classes) {
      const ClassInfo* info = table.find(c);
      options.colors.push_back(info ? info->color : Rgb{160, 160, 160});
    }
    return writePly(path, cloud, options);
  }
  unknownFormat(path);
}

}  // namespace hazmap
