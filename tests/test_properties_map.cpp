// Camera labels downstream of the labeller: property ICP on labels that do not mark a class's
// whole extent (ClassInfo::whole_extent), and the named channels (temperature, NIR reflectance,
// dose rate, …) from the sequence folder through the map to each hazard's mean and max.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/registration/registration.hpp"
#include "hazmap/registration/registration_target.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "test_helpers.hpp"

namespace hazmap {
namespace {

namespace fs = std::filesystem;

// A straight corridor along y (floor and two walls): its geometry says nothing about where along
// y a scan was taken. The right wall carries a heat patch labelled over y ∈ [y0, y1].
LabeledCloud corridor(double y0, double y1) {
  LabeledCloud c;
  const auto add = [&](double x, double y, double z, ClassId cls) { c.push_back(Eigen::Vector3f(x, y, z), cls); };
  for (int iy = -100; iy <= 100; ++iy) {
    const double y = 0.1 * iy;
    for (int ix = -20; ix <= 20; ++ix) add(0.1 * ix, y, 0.0, 0);
    for (int iz = 1; iz <= 20; ++iz) {
      const double z = 0.1 * iz;
      add(-2.0, y, z, 0);
      const bool hot = y >= y0 - 1e-9 && y <= y1 + 1e-9 && z >= 0.5 && z <= 1.5;
      add(2.0, y, z, hot ? 1 : 0);
    }
  }
  return c;
}

double alongCorridor(const LabeledCloud& source, const LabeledCloud& target, bool whole_extent) {
  ClassTable table = ClassTable::defaults();
  ClassInfo heat = table.at(1);
  heat.whole_extent = whole_extent;
  table.add(heat);
  const RegistrationResult r = registerClouds(source, target, Eigen::Isometry3d::Identity(), table);
  return r.transform.translation().y();
}

}  // namespace

// A camera saw the panel's first 2 m from one place and the 2 m after its first metre from the
// next: the same panel, cut by the view. Read as whole-extent labels (the 3-D residual pulls
// the two patches onto each other) the scans slide along the corridor; read as camera labels
// (plane residual, default search radius) they stay where the geometry put them.
TEST(PropertyIcpCameraLabels, PatchesCutByTheViewDoNotPullScansAlongTheWall) {
  const LabeledCloud target = corridor(0.0, 2.0);
  const LabeledCloud source = corridor(1.0, 3.0);  // the same place, the patch cut elsewhere
  EXPECT_GT(std::abs(alongCorridor(source, target, /*whole_extent=*/true)), 0.3);
  EXPECT_LT(std::abs(alongCorridor(source, target, /*whole_extent=*/false)), 0.02);
  // The same cut in both scans: no slide either way.
  EXPECT_LT(std::abs(alongCorridor(target, target, /*whole_extent=*/true)), 0.02);
}

// "Not observed" (NaN value, no property class: no camera saw the point) is not "observed and
// none": it pairs with the nearest point of any class, without the mismatch penalty α, on either
// side of the pair. Observed points of differing classes still pay α.
TEST(PropertyIcpCameraLabels, UnobservedPointsPairWithoutTheMismatchPenalty) {
  ClassTable table = ClassTable::defaults();
  table.mismatch_penalty = 1.0;
  RegistrationConfig cfg;
  cfg.metric = IcpMetric::PointToPoint;
  LabeledCloud target;
  target.enableProperty();
  target.push_back({0.1f, 0, 0}, 1, 0, 0, 80.0f);   // 0: heat, observed (80 °C)
  target.push_back({0.5f, 0, 0}, 0, 0, 0, 20.0f);   // 1: none, observed cold
  target.push_back({0, -0.3f, 0}, 0, 0, 0, NAN);    // 2: none, not observed
  const RegistrationTarget t(target, table, cfg);
  // An unobserved source point pairs with the nearest point whatever its class, without α.
  TargetMatch m = t.match({0.05f, 0, 0}, 0, NAN, INFINITY, /*observed=*/false);
  EXPECT_EQ(m.index, 0);
  EXPECT_TRUE(m.unobserved);
  EXPECT_NEAR(m.cost, 0.0025, 1e-6);
  // The same point observed cold pays α for the heat point: the unobserved one wins.
  m = t.match({0.05f, 0, 0}, 0, 20.0f);
  EXPECT_EQ(m.index, 2);
  EXPECT_TRUE(m.unobserved);
  EXPECT_NEAR(m.cost, 0.05f * 0.05f + 0.09f, 1e-6);
  // An observed heat point: its own class first; an unobserved point nearer than it wins
  // without α; an observed none point never beats it.
  EXPECT_EQ(t.match({0.3f, 0, 0}, 1, 80.0f).index, 0);
  EXPECT_EQ(t.match({0, -0.25f, 0}, 1, 80.0f).index, 2);
  m = t.match({0.7f, 0, 0}, 1, 80.0f);  // heat at 0.36 m² beats none at 0.04 + α
  EXPECT_EQ(m.index, 0);
  EXPECT_FALSE(m.cross_class);
  // The label gate's nearest-any-class search reports which target points were observed.
  EXPECT_TRUE(t.nearestAnyClass({0, -0.3f, 0}, 1).unobserved);
  EXPECT_FALSE(t.nearestAnyClass({0.5f, 0, 0}, 1).unobserved);
  // Observed shares: one heat point among two observed ones.
  EXPECT_DOUBLE_EQ(t.classShare(1), 0.5);
}

// The cost bound (ICP's previous partner) never changes the answer, observed or not.
TEST(PropertyIcpCameraLabels, CostBoundIsExactWithUnobservedPoints) {
  const ClassTable table = ClassTable::defaults();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::uniform_int_distribution<int> cls(0, 3), coin(0, 2);
  LabeledCloud target;
  target.enableProperty();
  for (int i = 0; i < 3000; ++i) {
    const auto c = static_cast<ClassId>(cls(rng) == 3 ? cls(rng) : 0);
    target.push_back({u(rng), u(rng), 0.3f * u(rng)}, c, 0, 0, c == 0 && coin(rng) == 0 ? NAN : 20.0f);
  }
  const RegistrationTarget t(target, table, RegistrationConfig{});
  std::uniform_int_distribution<int> pick(-1, 2999);
  int bounded = 0;
  for (int q = 0; q < 3000; ++q) {
    const Eigen::Vector3f p(u(rng), u(rng), 0.3f * u(rng));
    const auto c = static_cast<ClassId>(cls(rng));
    const bool observed = c != 0 || coin(rng) != 0;
    const float bound = t.costBound(p, c, pick(rng), true, observed);
    bounded += std::isfinite(bound);
    const TargetMatch free = t.match(p, c, NAN, INFINITY, observed);
    const TargetMatch tight = t.match(p, c, NAN, bound, observed);
    ASSERT_EQ(free.index, tight.index) << "query " << q << " class " << int(c) << " observed " << observed;
    if (free.index >= 0) EXPECT_LE(free.cost, bound);
  }
  EXPECT_GT(bounded, 100);
}

// Downsampling averages the values that were observed: a voxel is unobserved only when none of
// its points was (the mean with a NaN would have made a half-seen voxel unobserved).
TEST(PropertyIcpCameraLabels, DownsampledVoxelKeepsTheValuesObserved) {
  LabeledCloud c;
  c.enableProperty();
  c.push_back({0.01f, 0.01f, 0.01f}, 0, 0, 0, 30.0f);
  c.push_back({0.02f, 0.02f, 0.02f}, 0, 0, 0, NAN);
  c.push_back({0.03f, 0.03f, 0.03f}, 0, 0, 0, 40.0f);
  c.push_back({5.01f, 0.01f, 0.01f}, 0, 0, 0, NAN);
  c.push_back({5.02f, 0.02f, 0.02f}, 0, 0, 0, NAN);
  VoxelDownsampleConfig vd;
  vd.voxel_size = 1.0;
  const LabeledCloud d = voxelDownsample(c, vd);
  ASSERT_EQ(d.size(), 2u);
  const std::size_t seen = d.points[0].x() < 1.0f ? 0 : 1;
  EXPECT_FLOAT_EQ(d.property[seen], 35.0f);
  EXPECT_TRUE(std::isnan(d.property[1 - seen]));
}

TEST(PropertyIcpCameraLabels, WholeExtentRoundTripsThroughTheClassTableYaml) {
  ClassTable table = ClassTable::defaults();
  ClassInfo heat = table.at(1);
  heat.whole_extent = false;
  table.add(heat);
  const std::string yaml = table.toYamlString();
  EXPECT_EQ(ClassTable::defaults().toYamlString().find("whole_extent"), std::string::npos);  // old tables unchanged
  const ClassTable back = ClassTable::fromYamlString(yaml, "t.yaml");
  EXPECT_FALSE(back.at(1).whole_extent);
  EXPECT_TRUE(back.at(2).whole_extent);
  EXPECT_THROW(ClassTable::fromYamlString("classes:\n  - {id: 1, name: a, whole_extent: maybe}", "t.yaml"), Error);
}

namespace {

// Two property points (heat) and one plain point per scan, with two channels.
LabeledCloud scanOf(float temperature) {
  LabeledCloud c;
  c.enableProperty();
  c.push_back(Eigen::Vector3f(1.01f, 0.01f, 0.01f), 1, 0.0f, 0.0, temperature);
  c.push_back(Eigen::Vector3f(1.02f, 0.02f, 0.02f), 1, 0.0f, 0.0, std::nanf(""));
  c.push_back(Eigen::Vector3f(3.01f, 0.01f, 0.01f), 0, 0.0f, 0.0, 500.0f);  // not a hazard point
  return c;
}

}  // namespace

TEST(MapChannels, EachCellKeepsMeanAndMaxOfEveryChannelOverItsPropertyPoints) {
  GlobalMap map(GlobalMapConfig{}, ClassTable::defaults());
  const Eigen::Isometry3d I = Eigen::Isometry3d::Identity();
  std::vector<PointChannel> channels{{"temperature", {70.0f, std::nanf(""), 500.0f}}, {"dose_rate", {12.0f, 30.0f, 99.0f}}};
  map.insert(0, scanOf(70.0f), I, channels);
  channels[0].values[0] = 90.0f;
  channels[1].values = {2.0f, std::nanf(""), 99.0f};
  map.insert(1, scanOf(90.0f), I, channels);
  ASSERT_EQ(map.channelNames(), (std::vector<std::string>{"temperature", "dose_rate"}));
  bool found = false;
  for (const MapCell& cell : map.cells()) {
    ASSERT_EQ(cell.channels.size(), 2u);
    if (cell.label != 1) {
      EXPECT_EQ(cell.channels[0].samples, 0u);  // the plain point's 500 °C is not a hazard's
      continue;
    }
    found = true;
    EXPECT_EQ(cell.channels[0].samples, 2u);  // NaN = not observed, ignored
    EXPECT_FLOAT_EQ(cell.channels[0].mean, 80.0f);
    EXPECT_FLOAT_EQ(cell.channels[0].max, 90.0f);
    EXPECT_EQ(cell.channels[1].samples, 3u);
    EXPECT_FLOAT_EQ(cell.channels[1].mean, (12.0f + 30.0f + 2.0f) / 3.0f);
    EXPECT_FLOAT_EQ(cell.channels[1].max, 30.0f);
    EXPECT_FLOAT_EQ(cell.property_max, 90.0f);  // the property channel as before
  }
  EXPECT_TRUE(found);
  // Wrong length: one line naming the channel.
  std::vector<PointChannel> short_channel{{"temperature", {1.0f}}};
  EXPECT_THROW(map.insert(2, scanOf(1.0f), I, short_channel), Error);
}

TEST(MapChannels, CoarseningMergesTheChannelsAndHazardsReportEach) {
  GlobalMapConfig config;
  config.voxel_size = 0.1;
  config.max_voxels = 1000;
  GlobalMap map(config, ClassTable::defaults());
  // A 4 m × 4 m hot wall patch, 0.05 m spacing: 1600 cells at 0.1 m, > 1000 → coarsens.
  LabeledCloud wall;
  std::vector<PointChannel> channels{{"temperature", {}}, {"nir_reflectance", {}}};
  for (int i = 0; i < 80; ++i)
    for (int j = 0; j < 80; ++j) {
      wall.push_back(Eigen::Vector3f(5.02f, 0.05f * i + 0.01f, 0.05f * j + 0.01f), 1);
      channels[0].values.push_back(60.0f + 0.25f * float(i));  // 60 … 79.75 °C
      channels[1].values.push_back(i < 40 ? std::nanf("") : 0.5f);
    }
  map.insert(0, wall, Eigen::Isometry3d::Identity(), channels);
  ASSERT_GE(map.coarsenings(), 1);
  const std::vector<Hazard> hazards = findHazards(map);
  ASSERT_EQ(hazards.size(), 1u);
  const Hazard& h = hazards.front();
  ASSERT_EQ(h.channels.size(), 2u);
  EXPECT_EQ(h.channels[0].name, "temperature");
  EXPECT_EQ(h.channels[0].samples, 6400u);
  EXPECT_NEAR(*h.channels[0].mean, 69.875, 1e-3);
  EXPECT_NEAR(*h.channels[0].max, 79.75, 1e-4);
  EXPECT_EQ(h.channels[1].samples, 3200u);
  EXPECT_NEAR(*h.channels[1].max, 0.5, 1e-6);
  EXPECT_FALSE(h.mean_property);  // the scan had no LabeledCloud::property

  const fs::path dir = test::scratchDir();
  writeHazardsJson(dir / "hazards.json", hazards, map.voxelSize());
  writeHazardsCsv(dir / "hazards.csv", hazards);
  const auto j = nlohmann::json::parse(readTextFile(dir / "hazards.json"));
  EXPECT_NEAR(j["hazards"][0]["channels"]["temperature"]["max"].get<double>(), 79.75, 1e-4);
  EXPECT_EQ(j["hazards"][0]["channels"]["nir_reflectance"]["samples"].get<int>(), 3200);
  const std::vector<Hazard> back = readHazardsJson(dir / "hazards.json");
  ASSERT_EQ(back.size(), 1u);
  ASSERT_EQ(back[0].channels.size(), 2u);
  bool temperature = false;
  for (const auto& c : back[0].channels)
    if (c.name == "temperature") temperature = c.max && std::abs(*c.max - 79.75) < 1e-4;
  EXPECT_TRUE(temperature);
  const std::string csv = readTextFile(dir / "hazards.csv");
  const std::string header = csv.substr(0, csv.find('\n'));
  EXPECT_NE(header.find(",max_property,temperature_mean,temperature_max,nir_reflectance_mean,nir_reflectance_max"),
            std::string::npos)
      << header;
}

TEST(MapChannels, SequenceFolderChannelsReachTheScans) {
  const fs::path dir = test::scratchDir() / "seq";
  SequenceWriter writer(dir, ClassTable::defaults());
  writer.setPropertyChannel("temperature");
  writer.setChannels({"temperature", "dose_rate"});
  LabeledCloud scan = scanOf(70.0f);
  writer.addFrame(scan);
  fs::create_directories(dir / "dose_rate");
  const std::vector<float> dose{1.0f, 2.0f, 3.0f};
  writeFileAtomically(dir / "dose_rate" / "000000.bin", [&](std::ostream& o) {
    o.write(reinterpret_cast<const char*>(dose.data()), std::streamsize(dose.size() * sizeof(float)));
  });
  writer.finish();
  const Sequence seq = Sequence::open(dir);
  ASSERT_EQ(seq.channels(), (std::vector<std::string>{"temperature", "dose_rate"}));
  auto source = sequenceScanSource(seq);
  const std::optional<Scan> s = source->next();
  ASSERT_TRUE(s);
  ASSERT_EQ(s->channels.size(), 2u);
  EXPECT_FLOAT_EQ(s->channels[0].values[0], 70.0f);
  EXPECT_EQ(s->channels[1].values, dose);
  // A pass that only tracks skips the channel files (ScanSourceOptions::read_channels): the
  // broken file below goes unread, the property channel still comes with the points.
  writeTextAtomically(dir / "dose_rate" / "000000.bin", "abc");
  ScanSourceOptions tracking;
  tracking.read_channels = false;
  const std::optional<Scan> t = openScanSource(dir, tracking)->next();
  ASSERT_TRUE(t);
  EXPECT_TRUE(t->channels.empty());
  ASSERT_EQ(t->cloud.property.size(), 3u);
  EXPECT_FLOAT_EQ(t->cloud.property[0], 70.0f);
  EXPECT_THROW((void)openScanSource(dir)->next(), Error);  // read by default (map assembly)
  // A channel file of the wrong size is a one-line error naming the file.
  writeTextAtomically(dir / "dose_rate" / "000000.bin", "abc");
  try {
    (void)Sequence::open(dir).frameChannels(0, 3);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dose_rate/000000.bin"), std::string::npos) << e.what();
  }
  // A listed channel without its folder.
  fs::remove_all(dir / "dose_rate");
  EXPECT_THROW((void)Sequence::open(dir), Error);
}

}  // namespace hazmap
