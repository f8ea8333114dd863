#pragma once
// Shared by the libFuzzer targets: the readers take paths, so each input is placed in an
// in-memory file (memfd) and read through /proc/self/fd/N — no disk I/O per run.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <string>

#include "hazmap/core/labeled_cloud.hpp"

namespace hazmap::fuzz {

class MemFile {
 public:
  explicit MemFile(const char* name) : fd_(::memfd_create(name, 0)) {
    if (fd_ < 0) std::abort();
    path_ = "/proc/self/fd/" + std::to_string(fd_);
  }
  ~MemFile() { ::close(fd_); }
  /// Replaces the contents and returns the path to read.
  const std::string& set(const std::uint8_t* data, std::size_t size) {
    if (::ftruncate(fd_, 0) != 0) std::abort();
    std::size_t done = 0;
    while (done < size) {
      const ssize_t w = ::pwrite(fd_, data + done, size - done, static_cast<off_t>(done));
      if (w <= 0) std::abort();
      done += static_cast<std::size_t>(w);
    }
    return path_;
  }

 private:
  int fd_;
  std::string path_;
};

/// The invariants every reader promises: aligned channels and only finite points.
inline void checkCloud(const LabeledCloud& c) {
  if (c.classes.size() != c.size()) std::abort();
  if (!c.intensity.empty() && c.intensity.size() != c.size()) std::abort();
  if (!c.timestamps.empty() && c.timestamps.size() != c.size()) std::abort();
  if (!c.property.empty() && c.property.size() != c.size()) std::abort();
  for (const auto& p : c.points)
    if (!p.allFinite()) std::abort();
}

}  // namespace hazmap::fuzz
