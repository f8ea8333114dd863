#pragma once
// The simulator config a demo run uses: the scenario, seed and frame count of the DemoConfig,
// the thermal camera when camera labels are asked for, and the DemoConfig's simulator settings
// (`section.key=value`, e.g. odometry.slip_probability=0.3 or robot.frame_distance=0.5) applied
// on top of the simulator's defaults — which stay the paper's specification.
#include <string>
#include <vector>

#include "hazmap/demo/demo.hpp"
#include "hazmap/sim/simulator.hpp"

namespace hazmap {

/// Applies every `section.key=value` in `settings` to `config` at once (so a pair such as
/// odometry.slip_min / slip_max is validated together, not one half at a time). Errors name
/// `where` and the key; scenario, seed and max_frames are refused (the demo sets them).
void applySimulatorSettings(sim::SimulatorConfig& config, const std::vector<std::string>& settings,
                            const std::string& where = "--sim-set");

/// The simulator config of `config` (validated; errors in the settings name `where`).
sim::SimulatorConfig demoSimulatorConfig(const DemoConfig& config, const std::string& where = "--sim-set");

}  // namespace hazmap
