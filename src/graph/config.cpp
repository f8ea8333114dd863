#include <yaml-cpp/yaml.h>

#include "hazmap/core/error.hpp"
#include "hazmap/graph/optimizer.hpp"

namespace hazmap {

PoseGraphConfig loadPoseGraphConfig(const std::filesystem::path& yaml_file) {
  const std::string file = yaml_file.string();
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    fail(file, "cannot open");
  } catch (const YAML::Exception& e) {
    fail(file, std::string("invalid YAML: ") + e.what());
  }
  YAML::Node node = root && root.IsMap() && root["graph"] ? root["graph"] : root;
  PoseGraphConfig c;
  if (!node || node.IsNull()) return c;
  if (!node.IsMap()) fail(file, "expected a map of pose-graph settings");
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    const std::string where = file + ": graph." + key;
    try {
      const YAML::Node& v = kv.second;
      if (key == "cost") c.cost = parsePoseGraphCost(v.as<std::string>(), where);
      else if (key == "init") c.init = parsePoseGraphInit(v.as<std::string>(), where);
      else if (key == "loop_loss") c.loop_loss = parseLoopLoss(v.as<std::string>(), where);
      else if (key == "loop_loss_scale") c.loop_loss_scale = v.as<double>();
      else if (key == "max_iterations") c.max_iterations = v.as<int>();
      else if (key == "function_tolerance") c.function_tolerance = v.as<double>();
      else if (key == "gradient_tolerance") c.gradient_tolerance = v.as<double>();
      else if (key == "parameter_tolerance") c.parameter_tolerance = v.as<double>();
      else if (key == "threads") c.threads = v.as<int>();
      else if (key == "verbose") c.verbose = v.as<bool>();
      else fail(where, "unknown key");
    } catch (const YAML::Exception&) {
      fail(where, "wrong value type");
    }
  }
  return c;
}

}  // namespace hazmap
