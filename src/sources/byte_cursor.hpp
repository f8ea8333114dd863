#pragma once
// Bounds-checked reads over a byte span, shared by the bag readers and the message decoders.
// Every read checks the remaining size first; a failure throws hazmap::Error naming `where`
// and the absolute offset (base + position), so a corrupt file reports where it broke.
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>

#include "hazmap/core/error.hpp"

namespace hazmap::sources {

class ByteCursor {
 public:
  ByteCursor(std::span<const std::uint8_t> bytes, const std::string& where,
             std::uint64_t base_offset = 0, bool big_endian = false)
      : bytes_(bytes), where_(where), base_(base_offset), big_endian_(big_endian) {}

  std::size_t position() const { return pos_; }
  std::size_t remaining() const { return bytes_.size() - pos_; }
  std::size_t size() const { return bytes_.size(); }
  bool atEnd() const { return pos_ == bytes_.size(); }
  std::uint64_t fileOffset() const { return base_ + pos_; }
  const std::string& where() const { return where_; }
  void setBigEndian(bool big) { big_endian_ = big; }

  template <class T>
  T read() {
    static_assert(std::is_arithmetic_v<T>);
    need(sizeof(T), "value");
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    if constexpr (sizeof(T) > 1) {
      if (big_endian_ != (std::endian::native == std::endian::big)) value = swapped(value);
    }
    return value;
  }

  std::span<const std::uint8_t> bytes(std::uint64_t n, const char* what = "bytes") {
    need(n, what);
    auto out = bytes_.subspan(pos_, static_cast<std::size_t>(n));
    pos_ += static_cast<std::size_t>(n);
    return out;
  }
  void skip(std::uint64_t n, const char* what = "bytes") { bytes(n, what); }
  /// Moves to an absolute position inside the span.
  void seek(std::uint64_t position) {
    if (position > bytes_.size()) failAt("offset " + std::to_string(base_ + position) + " past the end");
    pos_ = static_cast<std::size_t>(position);
  }
  /// Pads to a multiple of `n` counted from `origin` (CDR alignment).
  void align(std::size_t n, std::size_t origin) {
    if (pos_ < origin) return;
    const std::size_t pad = (n - (pos_ - origin) % n) % n;
    skip(pad, "alignment padding");
  }
  /// uint32 length + that many bytes (MCAP and ROS 1 strings).
  std::string lengthString(const char* what = "string") {
    const auto n = read<std::uint32_t>();
    const auto b = bytes(n, what);
    return std::string(reinterpret_cast<const char*>(b.data()), b.size());
  }
  void need(std::uint64_t n, const char* what) const {
    if (n > remaining())
      failAt("truncated: " + std::string(what) + " needs " + std::to_string(n) + " bytes, " +
             std::to_string(remaining()) + " left");
  }
  [[noreturn]] void failAt(const std::string& what) const {
    fail(where_, what + " (offset " + std::to_string(base_ + pos_) + ")");
  }

 private:
  template <class T>
  static T swapped(T v) {
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
    std::memcpy(&v, b, sizeof(T));
    return v;
  }
  std::span<const std::uint8_t> bytes_;
  std::string where_;
  std::uint64_t base_ = 0;
  std::size_t pos_ = 0;
  bool big_endian_ = false;
};

}  // namespace hazmap::sources
