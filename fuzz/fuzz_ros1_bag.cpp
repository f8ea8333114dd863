// libFuzzer target: the ROS 1 bag reader (bag header, index section or chunk scan, none/bz2/lz4
// chunks) and the ROS 1 decoders of the messages it yields.
#include "fuzz_bag.hpp"
#include "sources/bag_readers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz.bag");
  try {
    auto reader = hazmap::sources::openRos1Bag(file.set(data, size));
    hazmap::fuzz::drain(*reader);
  } catch (const hazmap::Error&) {
  }
  return 0;
}
