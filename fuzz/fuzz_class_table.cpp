// libFuzzer target: YAML class tables. A table that parses must survive a YAML round trip.
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
        again.unmapped_class != table.unmapped_class)
      std::abort();
    for (auto id : table.ids())
      if (again.at(id).name != table.at(id).name || again.at(id).kind != table.at(id).kind ||
          again.at(id).color != table.at(id).color)
        std::abort();
  } catch (const hazmap::Error&) {
    std::abort();  // hazmap wrote a table it cannot read back
  }
  return 0;
}
