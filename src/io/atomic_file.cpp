#include "hazmap/io/atomic_file.hpp"

#include <atomic>
#include <chrono>
#include <random>
#include <sstream>
#include <system_error>
#include <unistd.h>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {
std::string uniqueSuffix() {
  static std::atomic<unsigned> counter{0};
  const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
  std::ostringstream s;
  s << ::getpid() << "." << std::hex << (static_cast<unsigned long long>(now) & 0xFFFFFF) << "."
    << counter++;
  return s.str();
}
}  // namespace

AtomicFile::AtomicFile(std::filesystem::path destination) : destination_(std::move(destination)) {
  const auto dir = destination_.parent_path().empty() ? std::filesystem::path(".")
                                                      : destination_.parent_path();
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec))
    fail(destination_.string(), "output folder does not exist");
  temporary_ = dir / ("." + destination_.filename().string() + ".tmp." + uniqueSuffix());
  out_.open(temporary_, std::ios::binary | std::ios::trunc);
  if (!out_) fail(destination_.string(), "cannot open for writing");
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    out_.close();
    std::error_code ec;
    std::filesystem::remove(temporary_, ec);
  }
}

void AtomicFile::commit() {
  out_.flush();
  if (!out_) fail(destination_.string(), "write failed (disk full?)");
  out_.close();
  std::error_code ec;
  std::filesystem::rename(temporary_, destination_, ec);
  if (ec) fail(destination_.string(), "cannot rename temporary file: " + ec.message());
  committed_ = true;
}

void writeFileAtomically(const std::filesystem::path& destination,
                         const std::function<void(std::ostream&)>& write) {
  AtomicFile file(destination);
  write(file.stream());
  file.commit();
}

void writeTextAtomically(const std::filesystem::path& destination, const std::string& text) {
  writeFileAtomically(destination, [&](std::ostream& out) { out << text; });
}

std::string readTextFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), std::filesystem::exists(path) ? "cannot open" : "file not found");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace hazmap
