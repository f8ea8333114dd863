#pragma once
// KITTI Velodyne scans (.bin: float32 x, y, z, remission per point) and SemanticKITTI labels
// (.label: uint32 per point, low 16 bits semantic class, high 16 bits instance id).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/read_stats.hpp"

namespace hazmap {

/// Reads a .bin scan; remission goes to `intensity`, classes are 0. Non-finite points dropped.
LabeledCloud readKittiBin(const std::filesystem::path& bin, ReadStats* stats = nullptr);

/// Reads raw uint32 labels.
std::vector<std::uint32_t> readSemanticKittiLabels(const std::filesystem::path& label);

/// True when `labels` (raw .label values) look like SemanticKITTI's: every semantic id (low 16
/// bits) is one of its label set (0 unlabeled … 259 moving-other-vehicle) and at least one lies
/// outside hazmap's default classes 0-3, so the file cannot hold hazmap class ids.
bool looksLikeSemanticKittiLabels(const std::vector<std::uint32_t>& labels);

/// Reads a scan and (optionally) its labels; class = table.mapRaw(label & 0xFFFF). The label
/// count must equal the point count in the file (checked before non-finite points are dropped,
/// so labels stay aligned). Throws hazmap::Error naming the file on any problem.
LabeledCloud readKittiScan(const std::filesystem::path& bin,
                           const std::optional<std::filesystem::path>& label,
                           const ClassTable& table, ReadStats* stats = nullptr);

/// Writes x, y, z, intensity (0 when the cloud has none). Atomic.
void writeKittiBin(const std::filesystem::path& bin, const LabeledCloud& cloud);
/// Writes the class ids as labels (instance 0). Atomic.
void writeSemanticKittiLabels(const std::filesystem::path& label, const LabeledCloud& cloud);

}  // namespace hazmap
