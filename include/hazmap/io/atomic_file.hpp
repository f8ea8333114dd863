#pragma once
// Writers never leave a half-written file: they write into a temporary file in the destination's
// folder and rename it over the destination only once everything was written and flushed.
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace hazmap {

class AtomicFile {
 public:
  /// Opens "<dir>/.<name>.tmp.<random>" for binary writing. Throws hazmap::Error on failure.
  explicit AtomicFile(std::filesystem::path destination);
  ~AtomicFile();  ///< Removes the temporary file unless commit() succeeded.
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ofstream& stream() { return out_; }
  /// Flushes, checks the stream, closes and renames onto the destination.
  void commit();
  const std::filesystem::path& destination() const { return destination_; }

 private:
  std::filesystem::path destination_;
  std::filesystem::path temporary_;
  std::ofstream out_;
  bool committed_ = false;
};

/// Runs `write` on a stream and commits atomically; on any exception the destination is untouched.
void writeFileAtomically(const std::filesystem::path& destination,
                         const std::function<void(std::ostream&)>& write);

/// Writes a whole string atomically.
void writeTextAtomically(const std::filesystem::path& destination, const std::string& text);

/// Reads a whole file; throws hazmap::Error("<path>: cannot open ...") if it does not exist.
std::string readTextFile(const std::filesystem::path& path);

}  // namespace hazmap
