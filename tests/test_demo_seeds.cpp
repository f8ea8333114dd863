// Table 2 over seeds (demo/demo_seeds.hpp): the seed-list parser, the statistics, the aggregate,
// the simulator overrides the noise sweep uses, and `hazmap demo --seeds` end to end on a short route.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/demo/demo_seeds.hpp"
#include "hazmap/demo/demo_simulator.hpp"
#include "hazmap/demo/noise_sweep.hpp"
#include "hazmap/map/category_plot.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

using Seeds = std::vector<std::uint64_t>;

TEST(SeedList, RangesListsAndMixes) {
  EXPECT_EQ(parseSeedList("1-8"), (Seeds{1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(parseSeedList("1,3,5"), (Seeds{1, 3, 5}));
  EXPECT_EQ(parseSeedList("7"), (Seeds{7}));
  EXPECT_EQ(parseSeedList("4-4"), (Seeds{4}));
  EXPECT_EQ(parseSeedList("9,1-3"), (Seeds{9, 1, 2, 3}));
  EXPECT_EQ(parseSeedList("0-1"), (Seeds{0, 1}));
}

void expectSeedError(const std::string& text, const std::string& part) {
  try {
    parseSeedList(text);
    ADD_FAILURE() << "'" << text << "' was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--seeds"), std::string::npos) << e.what();
  }
}

TEST(SeedList, BadListsSayWhatIsWrong) {
  expectSeedError("", "no seeds");
  expectSeedError("1,,2", "'' is not a seed");
  expectSeedError("a-3", "'a' is not a seed");
  expectSeedError("1-", "'' is not a seed");
  expectSeedError("-3", "'' is not a seed");
  expectSeedError("1.5", "'1.5' is not a seed");
  expectSeedError("8-1", "runs backwards");
  expectSeedError("1-3,2", "seed 2 is listed twice");
  expectSeedError("1-20000", "more than 10000");
  expectSeedError("1 ,2", "'1 ' is not a seed");
}

TEST(SeedStats, MeanSampleSdMinMax) {
  const SeedStats s = seedStats({0.1, 0.2, 0.6});
  EXPECT_EQ(s.n, 3u);
  EXPECT_DOUBLE_EQ(s.mean, 0.3);
  // Σ(v − mean)² = 0.04 + 0.01 + 0.09 = 0.14, / (n − 1) = 0.07.
  EXPECT_NEAR(s.sd, std::sqrt(0.07), 1e-15);
  EXPECT_DOUBLE_EQ(s.min, 0.1);
  EXPECT_DOUBLE_EQ(s.max, 0.6);
  const SeedStats one = seedStats({0.25});
  EXPECT_EQ(one.sd, 0.0);
  EXPECT_EQ(one.mean, 0.25);
  EXPECT_EQ(seedStats({}).n, 0u);
}

DemoRow row(SlamMethod m, OdometryMode mode, double map, double ate) {
  DemoRow r;
  r.method = m;
  r.tracking = mode;
  r.map_error_m = map;
  r.ate_m = ate;
  return r;
}

TEST(SeedAggregate, MatchesRowsBySetUpAndMethod) {
  DemoReport a, b;
  a.rows = {row(SlamMethod::Icp, OdometryMode::FrameToFrame, 0.1, 1.0),
            row(SlamMethod::PropertyIcp, OdometryMode::FrameToFrame, 0.3, 3.0)};
  b.rows = {row(SlamMethod::Icp, OdometryMode::FrameToFrame, 0.2, 2.0),
            row(SlamMethod::PropertyIcp, OdometryMode::FrameToFrame, 0.5, 5.0)};
  a.rows[0].nees_odometry = 4.0;
  a.rows[0].odometry_edges = 10;
  b.rows[0].nees_odometry = 8.0;
  b.rows[0].odometry_edges = 10;
  b.rows[0].nees_loop = 3.0;
  b.rows[0].loop_edges = 2;  // seed a has no loop edges: its 0 must not count
  a.map_rows = {row(SlamMethod::Icp, OdometryMode::FrameToMap, 0.01, 0.1)};
  b.map_rows = {row(SlamMethod::Icp, OdometryMode::FrameToMap, 0.03, 0.3)};
  const auto agg = aggregateSeeds({a, b});
  ASSERT_EQ(agg.size(), 3u);
  EXPECT_EQ(agg[0].setup, DemoSetUp::FrameToFrame);
  EXPECT_EQ(agg[0].method, SlamMethod::Icp);
  EXPECT_NEAR(agg[0].map_error_m.mean, 0.15, 1e-15);
  EXPECT_NEAR(agg[0].map_error_m.sd, std::sqrt(0.005), 1e-15);
  EXPECT_NEAR(agg[0].nees_odometry.mean, 6.0, 1e-15);
  EXPECT_EQ(agg[0].nees_loop.n, 1u);
  EXPECT_NEAR(agg[0].nees_loop.mean, 3.0, 1e-15);
  EXPECT_NEAR(agg[1].map_error_m.mean, 0.4, 1e-15);
  EXPECT_NEAR(agg[1].ate_m.mean, 4.0, 1e-15);
  EXPECT_EQ(agg[2].setup, DemoSetUp::FrameToMap);
  EXPECT_NEAR(agg[2].map_error_m.mean, 0.02, 1e-15);
  EXPECT_EQ(agg[2].map_error_m.n, 2u);
  SeedsReport report;
  report.seeds = {1, 2};
  report.per_seed = {a, b};
  report.aggregate = agg;
  const std::string text = formatSeedsTables(report);
  EXPECT_NE(text.find("0.150 ± 0.071"), std::string::npos) << text;
  const auto j = nlohmann::json::parse(seedsJson(report));
  EXPECT_EQ(j.at("format"), "hazmap-table2-seeds/1");
  EXPECT_DOUBLE_EQ(j.at("aggregate").at("frame_to_map").at("icp").at("map_error_m").at("mean").get<double>(),
                   agg[2].map_error_m.mean);
  EXPECT_DOUBLE_EQ(j.at("per_seed").at("2").at("property-icp").at("map_error_m").get<double>(), 0.5);
}

TEST(DemoSimulator, SettingsOverrideOnlyWhatTheyName) {
  DemoConfig c;
  c.seed = 4;
  c.frames = 9;
  c.camera_labels = false;
  const sim::SimulatorConfig defaults = demoSimulatorConfig(c);
  EXPECT_EQ(defaults.seed, 4u);
  EXPECT_EQ(defaults.max_frames, 9u);
  EXPECT_TRUE(defaults.cameras.cameras.empty());
  // The pair is applied together: slip_min = 1.0 alone would exceed the default slip_max 0.5.
  c.simulator_settings = {"odometry.slip_min=1.0", "odometry.slip_max=2.0", "odometry.slip_probability=0.3",
                          "robot.frame_distance=0.5"};
  const sim::SimulatorConfig s = demoSimulatorConfig(c);
  EXPECT_EQ(s.odometry.slip_min, 1.0);
  EXPECT_EQ(s.odometry.slip_max, 2.0);
  EXPECT_EQ(s.odometry.slip_probability, 0.3);
  EXPECT_EQ(s.robot.frame_distance, 0.5);
  EXPECT_EQ(s.odometry.forward_scale_sigma, defaults.odometry.forward_scale_sigma);
  EXPECT_EQ(s.robot.frame_turn_deg, defaults.robot.frame_turn_deg);
  EXPECT_EQ(s.seed, 4u);
  // The simulator's own defaults are untouched by any of this.
  EXPECT_EQ(sim::OdometryNoiseConfig{}.slip_probability, 0.08);
  EXPECT_EQ(sim::RobotConfig{}.frame_distance, 1.0);
}

void expectSimSettingError(std::vector<std::string> settings, const std::string& part) {
  DemoConfig c;
  c.camera_labels = false;
  c.simulator_settings = std::move(settings);
  try {
    demoSimulatorConfig(c);
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(DemoSimulator, BadSettingsNameTheKey) {
  expectSimSettingError({"odometry.slip_probabilty=0.3"}, "slip_probabilty");
  expectSimSettingError({"odometry.slip_min=1.0"}, "slip_min");
  expectSimSettingError({"odometry.slip_probability=1.5"}, "slip_probability");
  expectSimSettingError({"robot.frame_distance=-1"}, "frame_distance");
  expectSimSettingError({"seed=3"}, "--seed");
  expectSimSettingError({"odometry.slip_probability"}, "section.key=value");
  expectSimSettingError({"odometry..x=1"}, "empty key part");
}

// The whole command on a short corridor: per-seed folders, each a single-seed demo whose
// table2.json is exactly what `hazmap demo --seed N` writes, and the aggregate over them.
TEST(DemoSeedsCli, TwoSeedsOnAShortRoute) {
  const auto dir = test::scratchDir();
  const std::string common = " --scenario corridor --frames 6 --no-camera-labels --threads 1";
  auto r = test::runCli("demo --seeds 1,2" + common + " --out " + (dir / "seeds").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("mean ± sd"), std::string::npos) << r.output;
  const auto j = nlohmann::json::parse(readTextFile(dir / "seeds" / "table2.json"));
  EXPECT_EQ(j.at("seeds"), nlohmann::json::array({1, 2}));
  for (const char* m : {"odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo"})
    for (const char* setup : {"frame_to_frame", "frame_to_map"}) {
      const auto& agg = j.at("aggregate").at(setup).at(m).at("map_error_m");
      const auto& s1 = j.at("per_seed").at("1");
      const auto& s2 = j.at("per_seed").at("2");
      const double v1 = std::string(setup) == "frame_to_map" ? s1.at("frame_to_map").at(m).at("map_error_m").get<double>()
                                                             : s1.at(m).at("map_error_m").get<double>();
      const double v2 = std::string(setup) == "frame_to_map" ? s2.at("frame_to_map").at(m).at("map_error_m").get<double>()
                                                             : s2.at(m).at("map_error_m").get<double>();
      EXPECT_NEAR(agg.at("mean").get<double>(), (v1 + v2) / 2, 1e-12) << m << " " << setup;
      EXPECT_NEAR(agg.at("sd").get<double>(), std::abs(v1 - v2) / std::sqrt(2.0), 1e-12) << m << " " << setup;
    }
  EXPECT_TRUE(std::filesystem::exists(dir / "seeds" / "seed-2" / "icp" / "run.json"));
  EXPECT_TRUE(std::filesystem::exists(dir / "seeds" / "seed-1" / "index.html"));
  const std::string index = readTextFile(dir / "seeds" / "index.html");
  EXPECT_NE(index.find("href=\"seed-2/index.html\""), std::string::npos);
  EXPECT_NE(index.find(fmt::format("{:.3f} ± {:.3f}", j.at("aggregate").at("frame_to_map").at("icp").at("map_error_m").at("mean").get<double>(),
                                   j.at("aggregate").at("frame_to_map").at("icp").at("map_error_m").at("sd").get<double>())),
            std::string::npos);
  // Seed 2's folder is the single-seed demo, bit for bit in its numbers.
  r = test::runCli("demo --seed 2" + common + " --out " + (dir / "single").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  auto single = nlohmann::json::parse(readTextFile(dir / "single" / "table2.json"));
  auto in_seeds = nlohmann::json::parse(readTextFile(dir / "seeds" / "seed-2" / "table2.json"));
  auto in_aggregate = j.at("per_seed").at("2");
  for (auto* t : {&single, &in_seeds, &in_aggregate})
    for (auto& [name, section] : t->items()) {  // speeds differ run to run
      if (section.contains("frames_per_s")) section.erase("frames_per_s");
      for (auto& [m, row] : section.items())
        if (row.is_object()) row.erase("frames_per_s");
    }
  EXPECT_EQ(single, in_seeds);
  EXPECT_EQ(in_aggregate, in_seeds);
  // Bad input: one line naming the option, nothing run.
  r = test::runCli("demo --seeds 3-1" + common + " --out " + (dir / "bad").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("--seeds: range 3-1"), std::string::npos) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
  r = test::runCli("demo --seeds 1 --seed 2" + common + " --out " + (dir / "bad").string());
  EXPECT_NE(r.exit_code, 0);
  std::filesystem::remove_all(dir);
}

TEST(NoiseSweep, AxesPairsAndCombinations) {
  const SweepAxis a = parseSweepAxis("odometry.slip_probability=0,0.08,0.3");
  EXPECT_EQ(a.keys, (std::vector<std::string>{"odometry.slip_probability"}));
  ASSERT_EQ(a.steps.size(), 3u);
  EXPECT_EQ(a.steps[2], (std::vector<std::string>{"0.3"}));
  EXPECT_EQ(a.name(), "slip_probability");
  const SweepAxis pair = parseSweepAxis("odometry.slip_min:odometry.slip_max=0.2:0.5,1:2");
  EXPECT_EQ(pair.name(), "slip_min:slip_max");
  EXPECT_EQ(pair.steps[1], (std::vector<std::string>{"1", "2"}));
  const SweepPoint c = parseSweepCombination("big slips@odometry.slip_min=1;odometry.slip_max=2");
  EXPECT_EQ(c.label, "big slips");
  EXPECT_EQ(c.settings, (std::vector<std::string>{"odometry.slip_min=1", "odometry.slip_max=2"}));
  for (const char* bad : {"odometry.slip_probability", "=1,2", "odometry.slip_probability=", "slip=1",
                          "odometry.slip_min:odometry.slip_max=0.2,1:2", "odometry.slip_probability=1,,2"})
    EXPECT_THROW(parseSweepAxis(bad), Error) << bad;
  for (const char* bad : {"odometry.slip_min=1", "@odometry.slip_min=1", "x@", "x@slip"})
    EXPECT_THROW(parseSweepCombination(bad), Error) << bad;
}

TEST(NoiseSweep, PointsCarryTheirOverridesToTheSimulator) {
  NoiseSweepConfig c;
  c.demo.camera_labels = false;
  c.axes = {parseSweepAxis("odometry.slip_min:odometry.slip_max=0.2:0.5,1:2"), parseSweepAxis("robot.frame_distance=2")};
  c.combinations = {parseSweepCombination("both@odometry.slip_probability=0.5;robot.frame_distance=0.5")};
  c.base = {"odometry.yaw_sigma_deg=0.5"};
  const auto points = sweepPoints(c);
  ASSERT_EQ(points.size(), 5u);
  EXPECT_EQ(points[0].label, "defaults");
  EXPECT_TRUE(points[0].settings.empty());
  EXPECT_EQ(points[2].id, "p02-slip_min_slip_max-1-2");
  EXPECT_EQ(points[4].axis, "combinations");
  DemoConfig d = c.demo;
  d.simulator_settings = c.base;
  d.simulator_settings.insert(d.simulator_settings.end(), points[2].settings.begin(), points[2].settings.end());
  const sim::SimulatorConfig s = demoSimulatorConfig(d);
  EXPECT_EQ(s.odometry.slip_min, 1.0);
  EXPECT_EQ(s.odometry.slip_max, 2.0);
  EXPECT_EQ(s.odometry.yaw_sigma_deg, 0.5);
  EXPECT_EQ(s.odometry.slip_probability, sim::OdometryNoiseConfig{}.slip_probability);
  EXPECT_EQ(s.robot.frame_distance, sim::RobotConfig{}.frame_distance);
  // A value the simulator refuses stops the sweep before anything runs.
  c.axes.push_back(parseSweepAxis("odometry.slip_probability=0.1,1.5"));
  EXPECT_THROW(sweepPoints(c), Error);
}

TEST(NoiseSweep, RatioIsIcpOverPropertyIcp) {
  SweepPointResult r;
  r.cells["frame_to_frame"]["icp"].map_error_m.mean = 0.3;
  r.cells["frame_to_frame"]["property-icp"].map_error_m.mean = 0.1;
  r.cells["frame_to_frame"]["icp+pgo"].map_error_m.mean = 0.2;
  r.cells["frame_to_frame"]["property-icp+pgo"].map_error_m.mean = 0.4;
  EXPECT_NEAR(r.ratio("frame_to_frame", false), 3.0, 1e-12);
  EXPECT_NEAR(r.ratio("frame_to_frame", true), 0.5, 1e-12);
  EXPECT_EQ(r.ratio("frame_to_map", false), 0.0);
}

TEST(CategoryPlot, DrawsAndRejectsMismatchedSeries) {
  CategoryPlotConfig pc;
  pc.categories = {"0", "0.08", "0.3"};
  const Image img = renderCategoryPlot({{"icp", {0.01, 0.1, std::nan("")}, {0, 0, 255}}}, pc);
  EXPECT_EQ(img.width, pc.width);
  EXPECT_THROW(renderCategoryPlot({{"icp", {0.01, 0.1}, {0, 0, 255}}}, pc), Error);
  pc.categories.clear();
  EXPECT_THROW(renderCategoryPlot({}, pc), Error);
}

// The command end to end on a short corridor: a step at the default runs once, the files are
// written, a second run reuses the finished points.
TEST(NoiseSweepCli, ShortCorridorWritesTableAndPlotAndResumes) {
  const auto dir = test::scratchDir();
  const std::string args = "noise-sweep --scenario corridor --frames 5 --seeds 1 --threads 1 --paper-only "
                           "--axis odometry.slip_probability=0.08,0.5 --out " + dir.string();
  auto r = test::runCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("same simulator settings as p00-defaults"), std::string::npos) << r.output;
  const auto j = nlohmann::json::parse(readTextFile(dir / "noise_sweep.json"));
  ASSERT_EQ(j.at("points").size(), 3u);
  const auto& high = j.at("points")[2];
  EXPECT_EQ(high.at("settings")[0], "odometry.slip_probability=0.5");
  const auto t2 = nlohmann::json::parse(readTextFile(dir / high.at("id").get<std::string>() / "table2.json"));
  EXPECT_DOUBLE_EQ(high.at("results").at("frame_to_frame").at("icp").at("map_error_mean_m").get<double>(),
                   t2.at("aggregate").at("frame_to_frame").at("icp").at("map_error_m").at("mean").get<double>());
  EXPECT_FALSE(high.at("results").contains("frame_to_map"));
  const std::string md = readTextFile(dir / "noise_sweep.md");
  EXPECT_NE(md.find("| slip_probability = 0.5 |"), std::string::npos) << md;
  EXPECT_TRUE(std::filesystem::exists(dir / "noise_sweep.png"));
  r = test::runCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reusing"), std::string::npos) << r.output;
  EXPECT_EQ(nlohmann::json::parse(readTextFile(dir / "noise_sweep.json")), j);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hazmap
