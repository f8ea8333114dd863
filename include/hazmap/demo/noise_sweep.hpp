#pragma once
// The odometry-noise sweep (issue 14): where does the paper's effect live? The demo (five
// methods, the paper's set-up and frame to map, over seeds) at simulator settings that vary the
// crawler's wheel slip (odometry.slip_probability, odometry.slip_min/slip_max) and the frame
// spacing (robot.frame_distance) one axis at a time around the defaults, plus named
// combinations. Writes per point a `demo --seeds` folder, and noise_sweep.json, noise_sweep.md
// (the table) and noise_sweep.png (map error per method against each axis, log scale).
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "hazmap/demo/demo_seeds.hpp"

namespace hazmap {

/// One axis: keys varied together, one value per key at each step.
/// Parsed from "odometry.slip_probability=0,0.08,0.3" or
/// "odometry.slip_min:odometry.slip_max=0.2:0.5,0.5:1,1:2".
struct SweepAxis {
  std::vector<std::string> keys;
  std::vector<std::vector<std::string>> steps;  ///< steps[i][k] = value of keys[k]
  std::string name() const;                     ///< "slip_probability", "slip_min:slip_max"
};
SweepAxis parseSweepAxis(const std::string& text, const std::string& where = "--axis");

/// One simulator setting set, run as a whole demo over the seeds.
struct SweepPoint {
  std::string id;     ///< folder name under the sweep's out folder
  std::string axis;   ///< "" for the defaults point, the axis name, or "combinations"
  std::string label;  ///< tick label: the value(s), or a combination's name
  std::vector<std::string> settings;  ///< simulator `section.key=value`
};

/// "worst@odometry.slip_probability=0.5;odometry.slip_max=2" → a named combination.
SweepPoint parseSweepCombination(const std::string& text, const std::string& where = "--point");

struct NoiseSweepConfig {
  DemoConfig demo;  ///< out_dir, scenario, frames, threads, frame_to_map (camera labels off)
  std::vector<std::uint64_t> seeds{1};
  std::vector<SweepAxis> axes;
  std::vector<SweepPoint> combinations;
  std::vector<std::string> base;  ///< simulator settings under every point
};

/// The points to run: the defaults first, then each axis' steps, then the combinations.
std::vector<SweepPoint> sweepPoints(const NoiseSweepConfig& config);

/// Mean ± sd over the seeds of one method in one set-up.
struct SweepCell {
  SeedStats map_error_m, ate_m;
};
struct SweepPointResult {
  SweepPoint point;
  std::map<std::string, std::map<std::string, SweepCell>> cells;  ///< [set-up][method]
  /// mean ICP map error / mean property-ICP map error (and with PGO) per set-up; > 1: property ICP wins.
  double ratio(const std::string& setup, bool pgo) const;
};

struct NoiseSweepReport {
  std::vector<SweepPointResult> points;
};

/// Runs (or, when <out>/<id>/table2.json was written for the same settings, reloads) every point
/// and writes noise_sweep.json, .md and .png into config.demo.out_dir.
NoiseSweepReport runNoiseSweep(const NoiseSweepConfig& config, std::ostream& out);

/// The markdown table (one row per point; per set-up the five methods' mean map error and the
/// ICP / property-ICP ratio).
std::string noiseSweepMarkdown(const NoiseSweepReport& report, const NoiseSweepConfig& config);

/// The figure: one panel per axis (and the combinations) and set-up.
void writeNoiseSweepPng(const std::filesystem::path& png, const NoiseSweepReport& report,
                        const NoiseSweepConfig& config);

}  // namespace hazmap
