// libFuzzer target: the CDR and ROS 1 message decoders and PointCloud2 → LabeledCloud for any
// layout. Input: one selector byte (decoder and serialization), then the message bytes.
#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/ros_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hazmap;
  if (size < 1) return 0;
  const Serialization s = (data[0] & 1) ? Serialization::Ros1 : Serialization::Cdr;
  const int which = (data[0] >> 1) % 7;
  const std::span<const std::uint8_t> bytes(data + 1, size - 1);
  try {
    switch (which) {
      case 0: {
        const PointCloud2 msg = decodePointCloud2(bytes, s, "f");
        fuzz::checkCloud(pointCloud2ToCloud(msg, "f"));
        if (s == Serialization::Cdr && decodePointCloud2(encodePointCloud2(msg), s, "f").data != msg.data) std::abort();
        break;
      }
      case 1:
        if (!decodeOdometry(bytes, s, "f").pose.matrix().allFinite()) std::abort();
        break;
      case 2: {
        const ImageMsg img = decodeImage(bytes, s, "f");
        if (std::uint64_t{img.step} * img.height > img.data.size()) std::abort();
        break;
      }
      case 3:
        for (const auto& p : decodeVelodyneScan(bytes, s, "f").packets)
          if (p.data.size() != 1206) std::abort();
        break;
      case 4: decodeOusterPacket(bytes, s, "f"); break;
      case 5: decodeString(bytes, s, "f"); break;
      default: decodePoseStamped(bytes, s, "f"); break;
    }
  } catch (const Error&) {
  }
  return 0;
}
