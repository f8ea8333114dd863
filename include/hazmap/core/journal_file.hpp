#pragma once
// An append-only temporary file for what a long mission no longer needs in memory (issue 33):
// created in the system's temporary folder (TMPDIR) and unlinked at once, so it goes with the
// process however it ends. Reads are positioned (pread), so they never disturb an append.
#include <cstddef>
#include <cstdint>
#include <string>

namespace hazmap {

class JournalFile {
 public:
  /// `what` names the journal in errors ("frame record journal"). Throws hazmap::Error when the
  /// temporary folder is missing or the file cannot be created.
  explicit JournalFile(std::string what);
  ~JournalFile();
  JournalFile(const JournalFile&) = delete;
  JournalFile& operator=(const JournalFile&) = delete;

  /// Appends `n` bytes; returns the offset they start at.
  std::uint64_t append(const void* bytes, std::size_t n);
  /// Reads `n` bytes from `offset`; throws hazmap::Error when the file does not hold them.
  void read(std::uint64_t offset, void* bytes, std::size_t n) const;
  std::uint64_t size() const { return end_; }
  /// Empties the file (what was appended is gone; the next append starts at 0).
  void clear();
  const std::string& what() const { return what_; }

 private:
  std::string what_;
  int fd_ = -1;
  std::uint64_t end_ = 0;
};

}  // namespace hazmap
