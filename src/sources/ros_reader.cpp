#include "ros_reader.hpp"

namespace hazmap::sources {

RosReader::RosReader(std::span<const std::uint8_t> bytes, Serialization s, const std::string& where)
    : cursor_(bytes, where), ros1_(s == Serialization::Ros1) {
  if (s == Serialization::Ros1) return;
  if (s != Serialization::Cdr) fail(where, "unsupported message serialization");
  // Encapsulation: 0x00 0x00 CDR big-endian, 0x00 0x01 CDR little-endian (ROS 2's); the
  // parameter-list and XCDR2 kinds are not used by ROS 2 for these types.
  if (bytes.size() < 4) cursor_.failAt("truncated: no 4-byte CDR encapsulation header");
  const std::uint8_t kind = bytes[1];
  if (bytes[0] != 0 || kind > 1)
    cursor_.failAt("unsupported CDR encapsulation 0x" + std::to_string(bytes[0]) + "/" +
                   std::to_string(kind) + " (expected plain CDR)");
  cursor_.setBigEndian(kind == 0);
  cursor_.skip(4);
}

std::string RosReader::string() {
  const auto n = prim<std::uint32_t>();
  const auto b = cursor_.bytes(n, "string");
  std::size_t len = b.size();
  if (!ros1_ && len > 0) {
    if (b[len - 1] != 0) failAt("CDR string without its terminating NUL");
    --len;
  }
  return std::string(reinterpret_cast<const char*>(b.data()), len);
}

std::uint32_t RosReader::count(std::size_t min_element_bytes, const char* what) {
  const auto n = prim<std::uint32_t>();
  if (min_element_bytes > 0 && n > cursor_.remaining() / min_element_bytes)
    failAt(std::string(what) + " count " + std::to_string(n) + " exceeds the " +
           std::to_string(cursor_.remaining()) + " bytes left");
  return n;
}

std::span<const std::uint8_t> RosReader::byteSequence(const char* what) {
  const auto n = count(1, what);
  return cursor_.bytes(n, what);
}

double RosReader::time() {
  if (ros1_) {
    const auto sec = prim<std::uint32_t>();
    const auto nsec = prim<std::uint32_t>();
    return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
  }
  const auto sec = prim<std::int32_t>();
  const auto nsec = prim<std::uint32_t>();
  return static_cast<double>(sec) + 1e-9 * static_cast<double>(nsec);
}

RosHeader RosReader::header() {
  RosHeader h;
  if (ros1_) prim<std::uint32_t>();  // seq
  h.stamp = time();
  h.frame_id = string();
  return h;
}

void RosReader::skipDoubles(std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) prim<double>();
}

}  // namespace hazmap::sources
