#include "hazmap/demo/demo_simulator.hpp"

#include <yaml-cpp/yaml.h>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {

void applySimulatorSettings(sim::SimulatorConfig& config, const std::vector<std::string>& settings,
                            const std::string& where) {
  if (settings.empty()) return;
  YAML::Node top(YAML::NodeType::Map);
  for (const std::string& assignment : settings) {
    const auto eq = assignment.find('=');
    if (eq == std::string::npos || eq == 0) fail(where, "expected section.key=value, got '" + assignment + "'");
    const std::string key = assignment.substr(0, eq);
    if (key == "scenario" || key == "seed" || key == "max_frames")
      fail(where, "'" + key + "' is set by the demo's own option (--scenario, --seed/--seeds, --frames)");
    // Walk/create the nested maps, then set the leaf (a later setting of the same key wins).
    YAML::Node node = top;
    std::size_t start = 0;
    for (auto dot = key.find('.'); dot != std::string::npos; start = dot + 1, dot = key.find('.', start)) {
      const std::string part = key.substr(start, dot - start);
      if (part.empty()) fail(where, "empty key part in '" + assignment + "'");
      if (!node[part] || !node[part].IsMap()) node[part] = YAML::Node(YAML::NodeType::Map);
      node.reset(node[part]);
    }
    const std::string leaf = key.substr(start);
    if (leaf.empty()) fail(where, "empty key part in '" + assignment + "'");
    node[leaf] = parseConfigYaml(assignment.substr(eq + 1), where);
  }
  config = readConfig(top, ConfigPlace{where, ""}, config);
  config.validate(where);
}

sim::SimulatorConfig demoSimulatorConfig(const DemoConfig& config, const std::string& where) {
  sim::SimulatorConfig sim_config;
  sim_config.scenario = config.scenario;
  sim_config.seed = config.seed;
  sim_config.max_frames = config.frames;
  if (config.camera_labels) sim_config.cameras.cameras = {sim::SimCameraConfig::forName("thermal"), sim::SimCameraConfig::forName("nir")};
  applySimulatorSettings(sim_config, config.simulator_settings, where);
  sim_config.validate("demo");
  return sim_config;
}

}  // namespace hazmap
