// libFuzzer target: YAML class tables. A table that parses must survive a YAML round trip.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hazmap::ClassTable table;
  try {
    table = hazmap::ClassTable::fromYamlString(text, "fuzz.yaml");
  } catch (const hazmap::Error&) {
    return 0;
  }
  try {
    const auto again = hazmap::ClassTable::fromYamlString(table.toYamlString(), "round-trip");
    if (again.ids() != table.ids() || again.rawMapping() != table.rawMapping() ||
        (table.hasRawMapping() && again.unmapped_class != table.unmapped_class)) {
      // (unmapped_class only matters, and is only written, together with raw_labels)
      std::fprintf(stderr, "round trip changed the table:\n%s\n", table.toYamlString().c_str());
      std::abort();
    }
    for (auto id : table.ids()) {
      // yaml-cpp's emitter replaces invalid UTF-8 in strings, so names are compared only when
      // they are plain printable ASCII.
      const std::string& name = table.at(id).name;
      const bool plain = std::all_of(name.begin(), name.end(), [](char c) { return c >= 0x20 && c < 0x7f; });
      if ((plain && again.at(id).name != name) || again.at(id).kind != table.at(id).kind ||
          again.at(id).color != table.at(id).color)
        std::abort();
    }
  } catch (const hazmap::Error& e) {
    std::fprintf(stderr, "round trip failed: %s\n%s\n", e.what(), table.toYamlString().c_str());
    std::abort();  // hazmap wrote a table it cannot read back
  }
  return 0;
}
