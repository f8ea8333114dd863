#pragma once
// PCD v0.7 (PCL's format). Reads DATA ascii / binary / binary_compressed with fields x y z and
// optional intensity, label (→ class via table.mapRaw), timestamp (or t/time); extra fields are
// skipped. Writes ascii, binary or binary_compressed, readable by PCL. Files hazmap writes carry
// the comment `# hazmap: label holds hazmap class ids`: their labels are read as class ids as-is
// (no raw-label mapping), so a written cloud reads back unchanged with any table.
#include <filesystem>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/read_stats.hpp"

namespace hazmap {

/// Ascii and Binary are what PCL's tools expect; BinaryCompressed (LZF) is smaller and also
/// readable by PCL.
enum class PcdEncoding { Ascii, Binary, BinaryCompressed };

LabeledCloud readPcd(const std::filesystem::path& path, const ClassTable& table = ClassTable::defaults(),
                     ReadStats* stats = nullptr);
/// Writes x y z [intensity] label [timestamp] [property]. Atomic.
void writePcd(const std::filesystem::path& path, const LabeledCloud& cloud,
              PcdEncoding encoding = PcdEncoding::Binary);

}  // namespace hazmap
