// libFuzzer target: hazards.json reader (`hazmap view`'s input).
#include <cmath>
#include <cstdlib>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/map/hazards.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("hazards.json");
  const std::string& path = file.set(data, size);
  try {
    for (const auto& h : hazmap::readHazardsJson(path))
      if (!h.centroid.allFinite() || !h.min.allFinite() || !h.max.allFinite() || !std::isfinite(h.area_m2) ||
          h.id < 0)
        std::abort();
  } catch (const hazmap::Error&) {
  }
  return 0;
}
