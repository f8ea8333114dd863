#include "hazmap/core/journal_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

std::string lastError() { return std::strerror(errno); }

}  // namespace

JournalFile::JournalFile(std::string what) : what_(std::move(what)) {
  std::error_code ec;
  const std::filesystem::path base = std::filesystem::temp_directory_path(ec);
  if (ec) {
    const char* tmpdir = std::getenv("TMPDIR");
    fail(what_, "no temporary folder" + (tmpdir ? " (TMPDIR=" + std::string(tmpdir) + ")" : std::string()) + ": " +
                    ec.message());
  }
  std::string path = (base / "hazmap-journal-XXXXXX").string();
  fd_ = ::mkstemp(path.data());
  if (fd_ < 0) fail(path, "cannot create the " + what_ + ": " + lastError());
  ::unlink(path.c_str());
}

JournalFile::~JournalFile() {
  if (fd_ >= 0) ::close(fd_);
}

std::uint64_t JournalFile::append(const void* bytes, std::size_t n) {
  const std::uint64_t at = end_;
  const auto* p = static_cast<const char*>(bytes);
  for (std::size_t done = 0; done < n;) {
    const ssize_t w = ::pwrite(fd_, p + done, n - done, static_cast<off_t>(at + done));
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) fail(what_, "cannot write: " + (w < 0 ? lastError() : std::string("no space")));
    done += static_cast<std::size_t>(w);
  }
  end_ += n;
  return at;
}

void JournalFile::clear() {
  if (::ftruncate(fd_, 0) != 0) fail(what_, "cannot empty: " + lastError());
  end_ = 0;
}

void JournalFile::read(std::uint64_t offset, void* bytes, std::size_t n) const {
  if (offset + n > end_)
    fail(what_, "cannot read " + std::to_string(n) + " bytes at " + std::to_string(offset) + ": it holds " +
                    std::to_string(end_));
  auto* p = static_cast<char*>(bytes);
  for (std::size_t done = 0; done < n;) {
    const ssize_t r = ::pread(fd_, p + done, n - done, static_cast<off_t>(offset + done));
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) fail(what_, "cannot read at " + std::to_string(offset + done) + ": " + (r < 0 ? lastError() : "cut short"));
    done += static_cast<std::size_t>(r);
  }
}

}  // namespace hazmap
