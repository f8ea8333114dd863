// libFuzzer target: the MCAP reader (summary/index path and linear scan, chunk decompression
// and CRC, time-ordered merge) and the decoders of the messages it yields.
#include "fuzz_bag.hpp"
#include "sources/bag_readers.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("fuzz.mcap");
  try {
    auto reader = hazmap::sources::openMcap(file.set(data, size));
    hazmap::fuzz::drain(*reader);
  } catch (const hazmap::Error&) {
  }
  return 0;
}
