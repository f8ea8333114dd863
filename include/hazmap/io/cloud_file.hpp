#pragma once
// Format-agnostic cloud reading/writing, chosen by extension: .bin (+ .label beside it or in a
// sibling labels/ folder), .pcd, .ply.
#include <filesystem>
#include <optional>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/read_stats.hpp"

namespace hazmap {

/// `label` overrides the automatic .label lookup for .bin files.
LabeledCloud readCloud(const std::filesystem::path& path, const ClassTable& table = ClassTable::defaults(),
                       ReadStats* stats = nullptr,
                       const std::optional<std::filesystem::path>& label = std::nullopt);

/// Writes by extension. For .bin, classes go to a .label file next to it (same stem) when any
/// point has a non-zero class. `table` supplies PLY colours.
void writeCloud(const std::filesystem::path& path, const LabeledCloud& cloud,
                const ClassTable& table = ClassTable::defaults());

}  // namespace hazmap
