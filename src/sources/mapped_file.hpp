#pragma once
// A whole file mapped read-only (bags are read in place: no copy of uncompressed chunks).
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>

namespace hazmap::sources {

class MappedFile {
 public:
  /// Throws hazmap::Error naming the path when it cannot be opened or mapped.
  explicit MappedFile(const std::filesystem::path& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  std::span<const std::uint8_t> bytes() const { return {data_, size_}; }
  std::size_t size() const { return size_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  const std::uint8_t* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace hazmap::sources
