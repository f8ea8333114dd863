#include "hazmap/io/temporary_folder.hpp"

#include <random>
#include <system_error>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace fs = std::filesystem;

fs::path temporarySibling(const fs::path& out) {
  const fs::path parent = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::random_device rd;
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path candidate =
        parent / ("." + out.filename().string() + ".partial-" + std::to_string(rd() % 1000000));
    if (!fs::exists(candidate)) return candidate;
  }
  fail(out.string(), "cannot find a free temporary folder name next to it");
}

TemporaryFolder::~TemporaryFolder() {
  if (!keep) {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
}

bool checkSequenceOutput(const fs::path& out, const std::string& shown, bool overwrite) {
  if (!fs::exists(out)) return false;
  if (!fs::is_directory(out)) fail(shown, "exists and is not a folder");
  const fs::path cwd = fs::current_path().lexically_normal();
  const auto rel = cwd.lexically_relative(out);
  if (!rel.empty() && *rel.begin() != "..")
    fail(shown, "is the current folder or contains it; choose another output folder");
  if (!fs::is_empty(out)) {
    if (!overwrite) fail(shown, "exists and is not empty (pass --overwrite to replace it)");
    // Only ever replace a previous sequence, never an arbitrary folder.
    if (!fs::exists(out / "hazmap.yaml") && !fs::exists(out / "velodyne"))
      fail(shown, "exists, is not empty and is not a hazmap sequence; refusing to replace it");
  }
  return true;
}

void commitFolder(TemporaryFolder& tmp, const fs::path& out, const std::string& shown, bool replace) {
  if (replace) fs::remove_all(out);
  std::error_code ec;
  fs::rename(tmp.path, out, ec);
  if (ec) fail(shown, "cannot move the finished sequence into place: " + ec.message());
  tmp.keep = true;
}

}  // namespace hazmap
