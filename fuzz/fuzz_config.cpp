// libFuzzer target: the config mechanism (core/config_fields.hpp) on YAML text, through the one
// table that lives in core (property_icp: a number and a name → number map). A config that reads
// must validate, write, and read back to the same JSON.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/property_icp_config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hazmap::PropertyIcpConfig config;
  try {
    config = hazmap::configFromYaml(text, "fuzz.yaml", "property_icp", hazmap::PropertyIcpConfig{});
  } catch (const hazmap::Error&) {
    return 0;
  }
  try {
    const std::string yaml = hazmap::configToYaml(config);
    const auto again = hazmap::configFromYaml(yaml, "round-trip", "property_icp", hazmap::PropertyIcpConfig{});
    if (hazmap::configToJson(again) != hazmap::configToJson(config)) {
      std::fprintf(stderr, "round trip changed the config:\n%s\n", yaml.c_str());
      std::abort();
    }
  } catch (const hazmap::Error& e) {
    std::fprintf(stderr, "round trip failed: %s\n%s\n", e.what(), hazmap::configToYaml(config).c_str());
    std::abort();
  }
  return 0;
}
