// Fuzz target: the label spool of `hazmap live --camera` (properties/live_labels.hpp), read back
// over three scans of three points: labels only where a whole record matches a scan, every
// channel as long as the scan, or a one-line hazmap::Error.
#include <cstdlib>

#include "fuzz_input.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/properties/live_labels.hpp"

namespace {

class ThreeScans final : public hazmap::ScanSource {
 public:
  std::optional<hazmap::Scan> next() override {
    if (next_ == 3) return std::nullopt;
    hazmap::Scan s;
    s.index = next_++;
    for (int i = 0; i < 3; ++i) s.cloud.push_back(Eigen::Vector3f(float(i), 0.0f, 1.0f));
    return s;
  }
  std::optional<std::size_t> size() const override { return 3; }
  const hazmap::ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return "three scans"; }

 private:
  std::size_t next_ = 0;
  hazmap::ClassTable table_ = hazmap::ClassTable::defaults();
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static hazmap::fuzz::MemFile file("live_labels.bin");
  const std::string& path = file.set(data, size);
  try {
    const auto scans = hazmap::relabelFromSpool(std::make_unique<ThreeScans>(), path);
    while (const auto s = scans->next()) {
      if (s->cloud.classes.size() != s->cloud.size()) std::abort();
      if (s->cloud.hasProperty() && s->cloud.property.size() != s->cloud.size()) std::abort();
      for (const auto& c : s->channels)
        if (c.values.size() != s->cloud.size()) std::abort();
    }
  } catch (const hazmap::Error&) {
  }
  return 0;
}
