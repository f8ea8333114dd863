#pragma once
// Reads ROS message fields in either serialization: ROS 2 CDR (4-byte encapsulation header,
// then primitives aligned to their size counted from the end of that header, strings with a
// trailing NUL) or ROS 1 (little-endian, unaligned, strings without NUL, Header with seq).
#include <cstdint>
#include <span>
#include <string>

#include "byte_cursor.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap::sources {

class RosReader {
 public:
  RosReader(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where);

  bool ros1() const { return ros1_; }
  template <class T>
  T prim() {
    if (!ros1_) cursor_.align(sizeof(T) > 8 ? 8 : sizeof(T), kCdrOrigin);
    return cursor_.template read<T>();
  }
  std::string string();
  /// An element count (uint32), checked against the bytes left: each element takes at least
  /// `min_element_bytes`.
  std::uint32_t count(std::size_t min_element_bytes, const char* what);
  /// uint8[] (with count) or uint8[N] (fixed, no count).
  std::span<const std::uint8_t> byteSequence(const char* what);
  std::span<const std::uint8_t> fixedBytes(std::size_t n, const char* what) { return cursor_.bytes(n, what); }
  /// builtin_interfaces/Time (CDR: int32 sec, uint32 nanosec) or ROS 1 time (uint32, uint32).
  double time();
  RosHeader header();
  void skipDoubles(std::size_t n);
  [[noreturn]] void failAt(const std::string& what) const { cursor_.failAt(what); }
  ByteCursor& cursor() { return cursor_; }

 private:
  static constexpr std::size_t kCdrOrigin = 4;
  ByteCursor cursor_;
  bool ros1_ = false;
};

}  // namespace hazmap::sources
