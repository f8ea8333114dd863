// The viewer's scene from a `hazmap run` output folder.
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/render.hpp"
#include "hazmap/map/viewer.hpp"

namespace hazmap {

namespace {

std::filesystem::path required(const std::filesystem::path& dir, const char* name) {
  const auto path = dir / name;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    fail(path.string(), "missing: `hazmap view` needs a `hazmap run` output folder with map.ply and hazards.json");
  return path;
}

// poses.txt of the sequence run.json names, when it has one pose per estimated pose.
std::optional<Trajectory> groundTruthOf(const std::filesystem::path& dir, std::size_t poses) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(dir / "run.json", ec)) return std::nullopt;
  std::filesystem::path sequence;
  try {
    const auto j = nlohmann::json::parse(readTextFile(dir / "run.json"));
    sequence = j.value("sequence", std::string());
  } catch (const nlohmann::json::exception& e) {
    fail((dir / "run.json").string(), std::string("not JSON: ") + e.what());
  }
  if (sequence.empty()) return std::nullopt;
  if (sequence.is_relative() && !std::filesystem::exists(sequence, ec)) sequence = dir / sequence;
  if (!std::filesystem::is_regular_file(sequence / "poses.txt", ec)) return std::nullopt;
  Trajectory truth = readKittiTrajectory(sequence / "poses.txt");
  if (truth.size() != poses) return std::nullopt;
  return truth;
}

}  // namespace

ViewerScene loadRunScene(const std::filesystem::path& run_dir, const ClassTable& classes) {
  std::error_code ec;
  if (!std::filesystem::is_directory(run_dir, ec)) fail(run_dir.string(), "not a folder");
  ViewerScene scene;
  scene.classes = classes;
  scene.source = run_dir.string();
  scene.map = readPly(required(run_dir, "map.ply"), classes);
  scene.hazards = readHazardsJson(required(run_dir, "hazards.json"));
  if (std::filesystem::is_regular_file(run_dir / "changes.json", ec)) scene.changes = readHazardChanges(run_dir / "changes.json");
  auto name = std::filesystem::absolute(run_dir).lexically_normal();
  if (name.filename().empty()) name = name.parent_path();
  scene.title = "hazmap: " + name.filename().string();
  if (std::filesystem::is_regular_file(run_dir / "trajectory.kitti", ec)) {
    const Trajectory estimate = readKittiTrajectory(run_dir / "trajectory.kitti");
    scene.trajectories.push_back({"estimate", positionsOf(estimate), {208, 64, 255}});
    if (const auto truth = groundTruthOf(run_dir, estimate.size()))
      scene.trajectories.push_back({"ground truth", positionsOf(*truth), {60, 220, 130}});
    // Hide an indoor map's ceiling as the run's top-down render does (1.5 m above the sensor).
    if (!estimate.empty()) {
      double z = 0;
      for (const auto& p : estimate.poses) z += p.translation().z();
      scene.clip_above = z / double(estimate.size()) + 1.5;
    }
  }
  return scene;
}

}  // namespace hazmap
