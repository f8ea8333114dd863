#pragma once
// Internal helpers shared by the io readers/writers (not installed): one bulk file read, typed
// scalar loads from raw bytes, line/token splitting with line numbers, number parsing that
// reports the offending token, and LZF (PCD binary_compressed).
#include <bit>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace hazmap::io_detail {

static_assert(std::endian::native == std::endian::little,
              "hazmap's binary readers assume a little-endian host");

/// A whole file in memory, read with one bulk read (no zero-initialisation).
struct FileBytes {
  std::unique_ptr<char[]> data;
  std::size_t size = 0;
  const char* begin() const { return data.get(); }
  std::string_view view() const { return {data.get(), size}; }
};

/// Reads the file in one go. Throws hazmap::Error("<path>: file not found" / "is a directory" /
/// "cannot open" / "read error").
FileBytes readFileBytes(const std::filesystem::path& path);

/// Scalar types of PCD / PLY fields.
enum class Scalar : std::uint8_t { I8, U8, I16, U16, I32, U32, I64, U64, F32, F64 };

constexpr std::size_t scalarSize(Scalar t) {
  switch (t) {
    case Scalar::I8: case Scalar::U8: return 1;
    case Scalar::I16: case Scalar::U16: return 2;
    case Scalar::I32: case Scalar::U32: case Scalar::F32: return 4;
    case Scalar::I64: case Scalar::U64: case Scalar::F64: return 8;
  }
  return 1;
}

template <typename T>
inline T loadRaw(const char* p, bool swap) {
  T v;
  if (!swap) {
    std::memcpy(&v, p, sizeof(T));
  } else {
    char b[sizeof(T)];
    for (std::size_t k = 0; k < sizeof(T); ++k) b[k] = p[sizeof(T) - 1 - k];
    std::memcpy(&v, b, sizeof(T));
  }
  return v;
}

/// Loads one scalar of type `t` at `p` as double (`swap` for big-endian data).
inline double loadScalar(const char* p, Scalar t, bool swap = false) {
  switch (t) {
    case Scalar::I8: return static_cast<double>(static_cast<std::int8_t>(*p));
    case Scalar::U8: return static_cast<double>(static_cast<std::uint8_t>(*p));
    case Scalar::I16: return loadRaw<std::int16_t>(p, swap);
    case Scalar::U16: return loadRaw<std::uint16_t>(p, swap);
    case Scalar::I32: return loadRaw<std::int32_t>(p, swap);
    case Scalar::U32: return loadRaw<std::uint32_t>(p, swap);
    case Scalar::I64: return static_cast<double>(loadRaw<std::int64_t>(p, swap));
    case Scalar::U64: return static_cast<double>(loadRaw<std::uint64_t>(p, swap));
    case Scalar::F32: return loadRaw<float>(p, swap);
    case Scalar::F64: return loadRaw<double>(p, swap);
  }
  return 0.0;
}

/// Iterates over the lines of a text (any of \n, \r\n), counting line numbers from `first_line`.
class LineReader {
 public:
  explicit LineReader(std::string_view text, std::size_t first_line = 1)
      : text_(text), next_line_(first_line) {}
  /// Next line without its terminator; false at the end of the text.
  bool next(std::string_view& line);
  /// Number of the line last returned by next().
  std::size_t lineNumber() const { return next_line_ - 1; }
  /// Byte offset just past the last line returned (and its terminator).
  std::size_t offset() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  std::size_t next_line_;
};

inline bool isBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

/// Splits a line at blanks into `out` (cleared first).
void splitTokens(std::string_view line, std::vector<std::string_view>& out);
/// The line without leading/trailing blanks.
std::string_view trim(std::string_view s);

/// Parses a decimal floating-point number (also "nan", "inf", a leading '+'); false if the whole
/// token is not a number.
bool parseDouble(std::string_view token, double& out);
/// Parses a non-negative integer; false if not an integer or out of range.
bool parseUint64(std::string_view token, std::uint64_t& out);

/// Throws hazmap::Error("<path>: line <n>: <what>").
[[noreturn]] void failAtLine(const std::filesystem::path& path, std::size_t line, const std::string& what);

/// Parses a number or throws "<path>: line <n>: '<token>' is not a number".
double numberAt(std::string_view token, const std::filesystem::path& path, std::size_t line);

std::string toLower(std::string_view s);
/// Lower-case extension including the dot (".pcd").
std::string extensionOf(const std::filesystem::path& path);

/// LZF (liblzf format, as PCL's binary_compressed uses). Returns the number of bytes written, or
/// 0 when the input is corrupt or does not fit into `out_len` bytes.
std::size_t lzfDecompress(const char* in, std::size_t in_len, char* out, std::size_t out_len);
/// Compresses `n` bytes into liblzf's format (always succeeds; may be slightly larger than n).
std::string lzfCompress(const char* in, std::size_t n);

/// Appends the shortest text that reads back to exactly the same value.
void appendNumber(std::string& out, double v);
void appendNumber(std::string& out, float v);
void appendNumber(std::string& out, std::uint64_t v);

}  // namespace hazmap::io_detail
