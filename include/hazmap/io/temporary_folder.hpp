#pragma once
// Writing a whole folder atomically: everything goes into a temporary sibling folder that is
// renamed onto the destination at the end, so a failure leaves no half-written output.
#include <filesystem>
#include <string>

namespace hazmap {

/// A sibling folder of `out` that does not exist yet (".<name>.partial-NNNNNN").
std::filesystem::path temporarySibling(const std::filesystem::path& out);

/// Removes the folder on destruction unless `keep` was set.
struct TemporaryFolder {
  std::filesystem::path path;
  bool keep = false;
  ~TemporaryFolder();
};

/// Checks an output folder for a writer of sequence folders: it must not exist, be empty, or
/// (with `overwrite`) be a previous sequence (hazmap.yaml or velodyne/), never the current
/// folder or an arbitrary one. Returns whether an existing folder will be replaced.
bool checkSequenceOutput(const std::filesystem::path& out, const std::string& shown, bool overwrite);

/// Moves a finished temporary folder onto `out` (replacing it when `replace`).
void commitFolder(TemporaryFolder& tmp, const std::filesystem::path& out, const std::string& shown, bool replace);

}  // namespace hazmap
