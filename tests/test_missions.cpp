// Issue 34 (missions): the reopenable map folder a run leaves (map/map_folder.hpp), its checks
// on bad folders, simulated missions and localisation in a prior map.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

// One short corridor run with its outputs, made once per test process.
const fs::path& corridorRun() {
  static const fs::path out = [] {
    const fs::path seq_dir = test::writeSimulatedSequence("missions-corridor", "corridor", 3, 30);
    const Sequence seq = Sequence::open(seq_dir);
    const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
    const SlamResult r = runSlam(seq, config);
    const fs::path dir = seq_dir.parent_path() / (seq_dir.filename().string() + "-run");
    OutputConfig outputs;
    outputs.write_pngs = false;
    outputs.write_viewer = false;
    writeRunOutputs(seq, r, config, outputs, dir);
    return dir;
  }();
  return out;
}

// A copy of the run's folder to damage.
fs::path copyOfRun() {
  const fs::path dir = test::scratchDir() / "map";
  fs::copy(corridorRun(), dir, fs::copy_options::recursive);
  return dir;
}

std::string openError(const fs::path& dir) {
  return test::errorOf([&] { openMap(dir); });
}

void editManifest(const fs::path& dir, const std::function<void(nlohmann::json&)>& edit) {
  nlohmann::json j = nlohmann::json::parse(readTextFile(dir / "map.json"));
  edit(j);
  writeTextAtomically(dir / "map.json", j.dump(1));
}

void expectOneLine(const std::string& error, const std::string& part) {
  EXPECT_NE(error.find(part), std::string::npos) << error;
  EXPECT_EQ(error.find('\n'), std::string::npos) << error;
}

}  // namespace

TEST(MapFolder, RunLeavesAMapThatReopens) {
  const MapFolder map = openMap(corridorRun());
  EXPECT_EQ(map.manifest().format, "hazmap-map/1");
  EXPECT_EQ(map.manifest().method, "property-icp+pgo");
  const Trajectory estimate = readKittiTrajectory(corridorRun() / "trajectory.kitti");
  ASSERT_EQ(map.manifest().frames, estimate.size());
  ASSERT_GE(map.keyframes().size(), 5u);  // 30 frames 1 m apart, a keyframe every 0.9 m or 0.2 rad
  EXPECT_EQ(map.keyframes().front().frame, 0u);
  std::size_t landmarks = 0;
  for (const auto& k : map.keyframes()) {
    // Poses as written to trajectory.kitti (which rounds to its printed digits).
    EXPECT_LT(test::transErr(k.pose, estimate.poses.at(k.frame)), 1e-6);
    landmarks += k.landmarks.size();
  }
  EXPECT_GT(landmarks, 0u);  // the corridor's heat panels and puddles
  const LabeledCloud cloud = map.loadKeyframe(1);
  EXPECT_EQ(cloud.size(), map.keyframes()[1].points);
  EXPECT_TRUE(map.classes().isProperty(1));
  // The simulated VLP-16 is mounted 0.5 m above the floor.
  EXPECT_NEAR(map.manifest().sensor_height, sim::SimulatorConfig{}.sensor.mount_height, 0.05);
  EXPECT_EQ(map.graph().numNodes(), static_cast<int>(estimate.size()));
  EXPECT_EQ(map.hazards().size(), readHazardsJson(corridorRun() / "hazards.json").size());
  const nlohmann::json params = nlohmann::json::parse(map.manifest().parameters_json);
  EXPECT_EQ(params["slam"]["keyframe_distance"], SlamConfig{}.keyframe_distance);
}

TEST(MapFolder, AFolderWithoutManifestIsRefused) {
  const fs::path dir = copyOfRun();
  fs::remove(dir / "map.json");
  expectOneLine(openError(dir), "map.json is missing");
  expectOneLine(openError(dir / "nowhere"), "no such map folder");
}

TEST(MapFolder, AnotherFormatIsRefused) {
  const fs::path dir = copyOfRun();
  editManifest(dir, [](nlohmann::json& j) { j["format"] = "hazmap-map/2"; });
  expectOneLine(openError(dir), "format 'hazmap-map/2' is not supported");
}

TEST(MapFolder, AMissingPieceIsNamed) {
  const fs::path dir = copyOfRun();
  editManifest(dir, [](nlohmann::json& j) { j.erase("keyframes"); });
  expectOneLine(openError(dir), "missing 'keyframes'");
  const fs::path dir2 = test::scratchDir() / "map2";
  fs::copy(corridorRun(), dir2, fs::copy_options::recursive);
  fs::remove(dir2 / "keyframes" / "000002.pcd");
  expectOneLine(openError(dir2), "keyframes/000002.pcd is missing");
}

TEST(MapFolder, ATruncatedOrChangedFileIsRefused) {
  const fs::path dir = copyOfRun();
  const fs::path g2o = dir / "graph.g2o";
  const auto size = fs::file_size(g2o);
  fs::resize_file(g2o, size / 2);
  expectOneLine(openError(dir), "graph.g2o has " + std::to_string(size / 2) + " bytes");
  fs::copy_file(corridorRun() / "graph.g2o", g2o, fs::copy_options::overwrite_existing);
  {
    std::fstream f(g2o, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(10);
    f.put('#');
  }
  expectOneLine(openError(dir), "graph.g2o does not match its checksum");
}

TEST(MapFolder, ABrokenManifestIsOneLine) {
  const fs::path dir = copyOfRun();
  const std::string text = readTextFile(dir / "map.json");
  writeTextAtomically(dir / "map.json", text.substr(0, text.size() / 3));
  expectOneLine(openError(dir), "broken manifest");
  EXPECT_NO_THROW(openMap(corridorRun()));  // the original still opens
  const fs::path outside = test::scratchDir() / "outside";
  fs::copy(corridorRun(), outside, fs::copy_options::recursive);
  editManifest(outside, [](nlohmann::json& j) { j["files"][0]["path"] = "../secret"; });
  expectOneLine(openError(outside), "outside the folder");
}

TEST(MapFolder, ARewriteInvalidatesTheOldManifestFirst) {
  const fs::path dir = copyOfRun();
  ASSERT_TRUE(fs::exists(dir / "map.json"));
  invalidateMapFolder(dir);
  expectOneLine(openError(dir), "map.json is missing");
}
