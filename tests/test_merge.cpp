// Issue 34 part 3 (hazmap merge, pipeline/merge_maps.hpp): maps of several missions placed in the
// first's frame and merged into one map folder; bad inputs refused in one line, leaving nothing.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <set>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/map/map_folder.hpp"
#include "hazmap/pipeline/merge_maps.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "pipeline/prior_search.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

// One short corridor run (its result and its folder), made once per test process.
struct CorridorRun {
  SlamResult result;
  fs::path dir;
};
const CorridorRun& corridorRun() {
  static const CorridorRun run = [] {
    const fs::path seq_dir = test::writeSimulatedSequence("merge-corridor", "corridor", 3, 30);
    const Sequence seq = Sequence::open(seq_dir);
    const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
    CorridorRun r{runSlam(seq, config), seq_dir.parent_path() / (seq_dir.filename().string() + "-run")};
    OutputConfig outputs;
    outputs.write_pngs = false;
    outputs.write_viewer = false;
    writeRunOutputs(seq, r.result, config, outputs, r.dir);
    return r;
  }();
  return run;
}

fs::path copyOf(const fs::path& from, const fs::path& to) {
  fs::copy(from, to, fs::copy_options::recursive);
  return to;
}

nlohmann::json readJson(const fs::path& path) { return nlohmann::json::parse(readTextFile(path)); }

Eigen::Isometry3d poseOf(const nlohmann::json& rows) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 12; ++i) (i % 4 < 3 ? T.linear()(i / 4, i % 4) : T.translation()(i / 4)) = rows[std::size_t(i)];
  return T;
}

// A failed merge: non-zero exit, one line naming `part`, and nothing written at --out (when it
// is not an input) or beside it.
void expectRefused(const std::string& args, const fs::path& out, const std::string& part, bool out_is_input = false) {
  const auto r = test::runCli("merge " + args + " --quiet --no-viewer --out " + out.string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  if (!out_is_input) EXPECT_FALSE(fs::exists(out / "map.json")) << out;
  for (const auto& e : fs::directory_iterator(out.parent_path()))
    EXPECT_EQ(e.path().filename().string().find(".partial-"), std::string::npos) << e.path();
}

// Simulates naraha missions 1..k (seed `seed`; `frames` > 0: only the first frames) under `dir`
// and runs them: mission 1 from its true start, the later ones with the start unknown (each in
// its own frame).
void simulateAndRunMissions(const fs::path& dir, int seed, int missions, int frames = 0) {
  for (int k = 1; k <= missions; ++k) {
    const std::string m = (dir / ("m" + std::to_string(k))).string(), r = (dir / ("r" + std::to_string(k))).string();
    auto out = test::runCli("simulate --scenario naraha --seed " + std::to_string(seed) + " --mission " +
                            std::to_string(k) + " --frames " + std::to_string(frames) + " --out " + m);
    ASSERT_EQ(out.exit_code, 0) << out.output;
    out = test::runCli("run " + m + " --quiet --no-viewer --threads 2 --out " + r + (k > 1 ? " --start-unknown" : ""));
    ASSERT_EQ(out.exit_code, 0) << out.output;
  }
}

double mapError(const nlohmann::json& merge, const std::string& what) {
  for (const auto& e : merge["map_error"])
    if (e["what"] == what) return e["mean"];
  ADD_FAILURE() << "no map error '" << what << "' in merge.json";
  return 1e9;
}

}  // namespace

// ---- graph_extras.json: what graph.g2o cannot say ----

TEST(MergeMapFolder, GraphKeepsItsEdgeKindsAndGravityPriors) {
  const CorridorRun& run = corridorRun();
  const PoseGraph g = openMap(run.dir).graph();
  ASSERT_EQ(g.numEdges(), run.result.graph.numEdges());
  for (int i = 0; i < g.numEdges(); ++i) EXPECT_EQ(g.edges[std::size_t(i)].kind, run.result.graph.edges[std::size_t(i)].kind) << i;
  ASSERT_EQ(g.gravity_priors.size(), run.result.graph.gravity_priors.size());
  EXPECT_GT(g.gravity_priors.size(), 0u);  // the simulator writes gravity.txt
  for (std::size_t i = 0; i < g.gravity_priors.size(); ++i) {
    EXPECT_EQ(g.gravity_priors[i].node, run.result.graph.gravity_priors[i].node);
    EXPECT_LT((g.gravity_priors[i].down - run.result.graph.gravity_priors[i].down).norm(), 1e-12);
  }
}

TEST(MergeMapFolder, BrokenGraphExtrasAreOneLine) {
  const fs::path dir = copyOf(corridorRun().dir, test::scratchDir() / "map");
  const std::string broken = "{\"edges\": 3, \"loop_edges\": [], \"map_anchor_edges\": []}";
  writeTextAtomically(dir / "graph_extras.json", broken);
  // Changed after map.json was written: the checksum refuses it before it is read.
  std::string e = test::errorOf([&] { openMap(dir); });
  EXPECT_NE(e.find("damaged map: graph_extras.json"), std::string::npos) << e;
  // Listed with its new size and checksum, it is read, and refused when the graph is asked for.
  nlohmann::json j = readJson(dir / "map.json");
  for (auto& f : j["files"])
    if (f["path"] == "graph_extras.json")
      f["bytes"] = broken.size(), f["fnv1a"] = fmt::format("{:016x}", fileChecksum(dir / "graph_extras.json"));
  writeTextAtomically(dir / "map.json", j.dump(1));
  const MapFolder map = openMap(dir);
  e = test::errorOf([&] { map.graph(); });
  EXPECT_NE(e.find("graph_extras.json: broken graph extras: describes 3 edges, graph.g2o has"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

// ---- bad input ----

TEST(MergeCli, BadInputsAreOneLineAndLeaveNothing) {
  const fs::path dir = test::scratchDir();
  const fs::path map = corridorRun().dir, out = dir / "merged";
  fs::create_directories(dir / "foreign");
  writeTextAtomically(dir / "foreign" / "notes.txt", "not a map\n");
  expectRefused(map.string() + " " + (dir / "foreign").string(), out, "not a hazmap map: map.json is missing");
  expectRefused(map.string(), out, "at least two map folders");
  expectRefused(map.string() + " " + map.string(), out, "is given twice");
  // A partial folder: a keyframe cloud gone (a run that died while writing, or a damaged copy).
  const fs::path partial = copyOf(map, dir / "partial");
  fs::remove(partial / "keyframes" / "000001.pcd");
  expectRefused(map.string() + " " + partial.string(), out, "partially written or damaged map: keyframes/000001.pcd");
  // --out is an input, or an arbitrary folder.
  const fs::path copy = copyOf(map, dir / "copy");
  expectRefused(map.string() + " " + copy.string(), copy, "is one of the maps to merge", true);
  EXPECT_NO_THROW(openMap(copy));  // untouched
  fs::create_directories(dir / "busy");
  writeTextAtomically(dir / "busy" / "thesis.tex", "\\begin{document}\n");
  expectRefused(map.string() + " " + copy.string(), dir / "busy", "exists and is not empty");
  EXPECT_TRUE(fs::exists(dir / "busy" / "thesis.tex"));
}

TEST(MergeCli, AnotherClassTableIsOneLine) {
  const fs::path dir = test::scratchDir();
  ClassTable t = ClassTable::defaults();
  ClassInfo c = t.at(2);
  c.name = "gamma", c.kind = PropertyKind::Radiation;
  t.add(c);
  writeTextAtomically(dir / "swapped.yaml", t.toYamlString());
  const fs::path seq = test::writeSimulatedSequence("merge-classes", "corridor", 3, 6);
  const auto r = test::runCli("run " + seq.string() + " --classes " + (dir / "swapped.yaml").string() +
                              " --quiet --no-viewer --out " + (dir / "other").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  expectRefused(corridorRun().dir.string() + " " + (dir / "other").string(), dir / "merged",
                "made with another class table: class 2 is 'gamma' (radiation) there, 'water' (water) here");
}

// ---- merging simulated missions ----
// (Each builds its missions; tens of seconds on a quiet machine.)

TEST(MergeScene, TwoMissionsGiveOneMapFolderThatMergesAgain) {
  const fs::path dir = test::scratchDir();
  simulateAndRunMissions(dir, 2, 2);
  if (HasFatalFailure()) return;
  auto r = test::runCli("merge " + (dir / "r1").string() + " " + (dir / "r2").string() +
                        " --threads 2 --no-viewer --out " + (dir / "merged").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2 of 2 maps placed"), std::string::npos) << r.output;
  const nlohmann::json merge = readJson(dir / "merged" / "merge.json");
  ASSERT_TRUE(merge["maps"][1]["placed"].get<bool>()) << merge["maps"][1].dump(1);
  // The map of both missions is no worse than mission 1's alone (+5 mm, the target).
  EXPECT_LE(mapError(merge, "merged"), mapError(merge, "first map alone") + 0.005);
  // Every inter-session loop verified, and none wrong against the truth (mission 1's frame).
  const Trajectory truth = readKittiTrajectory(dir / "m2" / "poses.txt");
  std::size_t accepted = 0;
  for (const auto& loop : merge["maps"][1]["loops"]) {
    if (!loop["accepted"].get<bool>()) continue;
    ++accepted;
    EXPECT_LT(test::transErr(poseOf(loop["pose"]), truth.poses.at(loop["frame"].get<std::size_t>())), 0.3);
  }
  EXPECT_EQ(accepted, merge["pose_graph"]["inter_session_loops"].get<std::size_t>());
  EXPECT_GT(accepted, 10u);
  // The merge is a map folder: every keyframe of both, every frame of both.
  const MapFolder merged = openMap(dir / "merged");
  const MapFolder m1 = openMap(dir / "r1"), m2 = openMap(dir / "r2");
  EXPECT_EQ(merged.keyframes().size(), m1.keyframes().size() + m2.keyframes().size());
  EXPECT_EQ(merged.manifest().frames, m1.manifest().frames + m2.manifest().frames);
  EXPECT_EQ(merged.graph().numNodes(), static_cast<int>(merged.manifest().frames));
  // ... with its search overview: a later mission localises in it without reading every keyframe.
  ASSERT_TRUE(merged.manifest().search_overview.has_value());
  const SlamConfig config = SlamConfig::forMethod(SlamMethod::PropertyIcpPgo);
  const pipeline_detail::PriorIndex index(merged, config.property_icp.applyTo(merged.classes()), config);
  EXPECT_TRUE(index.usedStoredOverview());
  EXPECT_EQ(index.size(), merged.keyframes().size());
  // What changed, mission 2 against mission 1: the removed source gone, the machine moved 2 m.
  std::set<std::string> kinds;
  const nlohmann::json changes = readJson(dir / "merged" / "changes.json");
  for (const auto& c : changes["changes"]) {
    EXPECT_EQ(c["mission"], 2);
    for (const auto& k : c["kinds"]) kinds.insert(k.get<std::string>());
  }
  EXPECT_TRUE(kinds.count("gone") && kinds.count("moved")) << readTextFile(dir / "merged" / "changes.csv");
  // ... and it can be merged again: mission 2 placed in the merge once more.
  r = test::runCli("merge " + (dir / "merged").string() + " " + (dir / "r2").string() +
                   " --threads 2 --quiet --no-viewer --out " + (dir / "again").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(readJson(dir / "again" / "merge.json")["maps"][1]["placed"].get<bool>());
  EXPECT_NO_THROW(openMap(dir / "again"));
}

TEST(MergeScene, ACopyOfItselfLandsInPlaceAndAnUnplaceableMapIsLeftOut) {
  const fs::path dir = test::scratchDir();
  simulateAndRunMissions(dir, 1, 1, 50);
  if (HasFatalFailure()) return;
  copyOf(dir / "r1", dir / "copy");
  MergeOptions options;
  options.threads = 2;
  options.write_viewer = options.write_pngs = false;
  // An open field of tanks: another site.
  const fs::path tanks = test::writeSimulatedSequence("merge-tanks", "tanks", 1, 20);
  const auto run = test::runCli("run " + tanks.string() + " --quiet --no-viewer --threads 2 --out " + (dir / "tanks").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // A corridor of another building: two answers in the map's own corridor agree, but most of its
  // keyframes do not verify there (the placement is not confirmed).
  const MergeReport report = mergeMaps({dir / "r1", dir / "copy", dir / "tanks", corridorRun().dir}, dir / "merged", options);
  ASSERT_EQ(report.maps.size(), 4u);
  ASSERT_TRUE(report.maps[1].placed);
  const Eigen::Isometry3d& T = report.maps[1].localisation.T_prior_run;
  EXPECT_LT(test::transErr(T, Eigen::Isometry3d::Identity()), 0.01);
  EXPECT_LT(test::rotErrDeg(T, Eigen::Isometry3d::Identity()), 0.1);
  // The tanks are another site: never placed, never guessed; reported and left out.
  EXPECT_FALSE(report.maps[2].placed);
  EXPECT_EQ(report.maps[2].localisation.state, PriorState::NeverLocalised);
  EXPECT_FALSE(report.maps[3].placed) << report.maps[3].localisation.optimisation_note;
  const MapFolder merged = openMap(dir / "merged");
  EXPECT_EQ(merged.keyframes().size(), 2 * openMap(dir / "r1").keyframes().size());
  ASSERT_FALSE(report.map_errors.empty()) << report.map_error_note;
  EXPECT_LE(report.map_errors[1].error.point.mean, report.map_errors[0].error.point.mean + 0.002);
  // Against itself nothing changed.
  const nlohmann::json changes = readJson(dir / "merged" / "changes.json");
  for (const auto& c : changes["changes"])
    for (const auto& k : c["kinds"]) EXPECT_TRUE(k == "unchanged" || k == "part_of") << c.dump();
}

// ---- real data ----

TEST(MergeReal, TwoHalvesOfAKittiSequenceMergeWhereTheWholeRunPutsThem) {
  // Real HDL-64 scans (SemanticKITTI sample, 6 frames, labels on the first 3) split in two, each
  // half run on its own (the second with its start unknown), then merged: the second half's
  // frames land where the whole sequence's own run puts them.
  const fs::path data = test::sharedData("kitti-semantic-sample");
  const fs::path dir = test::scratchDir();
  for (const char* part : {"a/velodyne", "a/labels", "b/velodyne"}) fs::create_directories(dir / part);
  for (int i = 0; i < 3; ++i) {  // the split of PriorMapReal (test_missions.cpp)
    const std::string n = "00000" + std::to_string(i), m = "00000" + std::to_string(i + 3);
    fs::create_symlink(data / "velodyne" / (n + ".bin"), dir / "a" / "velodyne" / (n + ".bin"));
    fs::create_symlink(data / "labels" / (n + ".label"), dir / "a" / "labels" / (n + ".label"));
    fs::create_symlink(data / "velodyne" / (m + ".bin"), dir / "b" / "velodyne" / (n + ".bin"));
  }
  const std::string common = " --classes semantic-kitti --quiet --no-viewer --threads 2 --out ";
  for (const auto& [in, out, flags] : {std::tuple{data, dir / "whole", ""}, std::tuple{dir / "a", dir / "ra", ""},
                                       std::tuple{dir / "b", dir / "rb", " --start-unknown"}}) {
    const auto r = test::runCli("run " + in.string() + flags + common + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
  }
  const auto r = test::runCli("merge " + (dir / "ra").string() + " " + (dir / "rb").string() +
                              " --threads 2 --quiet --no-viewer --out " + (dir / "merged").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json merge = readJson(dir / "merged" / "merge.json");
  ASSERT_TRUE(merge["maps"][1]["placed"].get<bool>()) << merge.dump(1);
  const Trajectory whole = readKittiTrajectory(dir / "whole" / "trajectory.kitti");
  const Trajectory merged = readKittiTrajectory(dir / "merged" / "trajectory.kitti");
  ASSERT_EQ(merged.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_LT(test::transErr(whole.poses[i], merged.poses[i]), 0.05) << i;
    EXPECT_LT(test::rotErrDeg(whole.poses[i], merged.poses[i]), 0.5) << i;
  }
  EXPECT_NO_THROW(openMap(dir / "merged"));
}
