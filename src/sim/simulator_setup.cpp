// Setting a simulator up from its config alone (built-in or user scene); apart from
// simulator.cpp because user scenes need the PLY reader.
#include "hazmap/core/error.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap::sim {

Scene loadConfiguredScene(const SimulatorConfig& config, const ClassTable& table) {
  if (!config.scene_file.empty()) return loadScene(config.scene_file, config.regions_file, table);
  Scene scene = builtinScene(config.scenario);
  scene.validate(table, "scenario " + config.scenario);
  return scene;
}

Simulator::Simulator(const SimulatorConfig& config) : config_(config) {
  config_.validate();
  table_ = ClassTable::load(config_.class_table);
  scene_ = loadConfiguredScene(config_, table_);
  init();
}

}  // namespace hazmap::sim
