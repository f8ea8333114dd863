// libFuzzer target: the simulator's config YAML (hazmap simulate --config), aimed at its
// `cameras:` section (a list of names or mappings, calibration errors, time offset). A config
// that reads and validates must write and read back to the same JSON, and every camera it
// configures must give a camera.yaml that hazmap's own camera reader accepts (what `simulate
// --cameras` writes beside the images): a config the simulator accepts must never produce a
// calibration that `hazmap label` then rejects.
#include <cstdio>
#include <cstdlib>
#include <string>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/sim/camera_sim.hpp"
#include "hazmap/sim/simulator.hpp"

namespace {

[[noreturn]] void abortWith(const std::string& what, const std::string& yaml) {
  std::fprintf(stderr, "%s\n%s\n", what.c_str(), yaml.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  hazmap::sim::SimulatorConfig config;
  try {
    config = hazmap::sim::SimulatorConfig::fromYamlString(text, "fuzz.yaml");
    config.validate("fuzz.yaml");
  } catch (const hazmap::Error&) {
    return 0;
  }
  const std::string yaml = config.toYamlString();
  try {
    const auto again = hazmap::sim::SimulatorConfig::fromYamlString(yaml, "round-trip");
    if (hazmap::configToJson(again) != hazmap::configToJson(config)) abortWith("round trip changed the config:", yaml);
  } catch (const hazmap::Error& e) {
    abortWith(std::string("round trip failed: ") + e.what(), yaml);
  }
  for (std::size_t k = 0; k < config.cameras.cameras.size(); ++k) {
    try {
      const auto written = hazmap::sim::writtenCalibration(config.cameras.cameras[k], config.cameras, config.seed, k);
      (void)hazmap::parseCameraYaml(hazmap::cameraYaml(written, ""), "camera.yaml");
    } catch (const hazmap::Error& e) {
      abortWith("camera " + std::to_string(k) + " gives a camera.yaml hazmap rejects: " + e.what(), yaml);
    }
  }
  return 0;
}
