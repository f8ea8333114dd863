#include <gtest/gtest.h>

#include <stb/stb_image.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/trajectory.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/map/export.hpp"
#include "hazmap/map/global_map.hpp"
#include "hazmap/map/hazards.hpp"
#include "hazmap/map/image.hpp"
#include "hazmap/map/outputs.hpp"
#include "hazmap/map/render.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

namespace {

constexpr ClassId kNone = 0, kHeat = 1, kWater = 2, kRadiation = 3;

// A flat square patch of points on z = `z`, `per_side`² points spaced `step`, one class.
void addPatch(LabeledCloud& c, Eigen::Vector2f origin, float size, float step, float z, ClassId cls,
              float property = 0.0f) {
  for (float y = 0; y < size - 1e-4f; y += step)
    for (float x = 0; x < size - 1e-4f; x += step)
      c.push_back({origin.x() + x + step / 2, origin.y() + y + step / 2, z}, cls, 0.0f, 0.0, property);
}

struct Decoded {
  int w = 0, h = 0;
  std::vector<std::uint8_t> rgb;
  Rgb at(int x, int y) const {
    const std::size_t i = (std::size_t(y) * std::size_t(w) + std::size_t(x)) * 3;
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};
Decoded readPngBack(const std::filesystem::path& path) {
  Decoded d;
  int n = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &d.w, &d.h, &n, 3);
  if (!data) return d;
  d.rgb.assign(data, data + std::size_t(d.w) * std::size_t(d.h) * 3);
  stbi_image_free(data);
  return d;
}
std::size_t countColor(const Decoded& d, Rgb c, int tol = 0) {
  std::size_t n = 0;
  for (int y = 0; y < d.h; ++y)
    for (int x = 0; x < d.w; ++x) {
      const Rgb p = d.at(x, y);
      if (std::abs(p[0] - c[0]) <= tol && std::abs(p[1] - c[1]) <= tol && std::abs(p[2] - c[2]) <= tol) ++n;
    }
  return n;
}

}  // namespace

// ---- GlobalMap ---------------------------------------------------------------------------------

TEST(GlobalMap, MajorityVoteCentroidAndTies) {
  GlobalMapConfig cfg;
  cfg.voxel_size = 1.0;
  GlobalMap map(cfg);
  LabeledCloud scan;
  // Cell (0,0,0): 3 heat + 2 none → heat. Cell (2,0,0): 1 water + 1 radiation → tie → water (2<3).
  for (float x : {0.1f, 0.2f, 0.3f}) scan.push_back({x, 0.5f, 0.5f}, kHeat);
  for (float x : {0.4f, 0.5f}) scan.push_back({x, 0.5f, 0.5f}, kNone);
  scan.push_back({2.2f, 0.5f, 0.5f}, kRadiation);
  scan.push_back({2.4f, 0.5f, 0.5f}, kWater);
  map.insert(0, scan, Eigen::Isometry3d::Identity());
  const auto cells = map.cells();
  ASSERT_EQ(cells.size(), 2u);
  EXPECT_EQ(cells[0].label, kHeat);
  EXPECT_EQ(cells[0].points, 5u);
  EXPECT_EQ(cells[0].label_points, 3u);
  EXPECT_NEAR(cells[0].centroid.x(), 0.3f, 1e-5);
  EXPECT_EQ(cells[1].label, kWater);
  EXPECT_NEAR(cells[1].centroid.x(), 2.3f, 1e-5);
  // Two more "none" points in cell 0 from a second frame flip the vote: 4 none vs 3 heat.
  LabeledCloud more;
  more.push_back({0.6f, 0.5f, 0.5f}, kNone);
  more.push_back({0.7f, 0.5f, 0.5f}, kNone);
  map.insert(1, more, Eigen::Isometry3d::Identity());
  EXPECT_EQ(map.cells()[0].label, kNone);
  const LabeledCloud cloud = map.cloud();
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.classes[0], kNone);
  EXPECT_EQ(map.frames(), 2u);
  EXPECT_EQ(map.pointsInserted(), 9u);
}

TEST(GlobalMap, PosesPlacePointsInTheWorld) {
  GlobalMap map;
  LabeledCloud scan;
  scan.push_back({1.0f, 0.0f, 0.0f}, kNone);
  map.insert(0, scan, fromXyzRpy(10, 20, 1, 0, 0, M_PI / 2));  // x axis → world y
  const auto cells = map.cells();
  ASSERT_EQ(cells.size(), 1u);
  EXPECT_NEAR(cells[0].centroid.x(), 10.0f, 1e-4);
  EXPECT_NEAR(cells[0].centroid.y(), 21.0f, 1e-4);
  EXPECT_NEAR(cells[0].centroid.z(), 1.0f, 1e-4);
}

TEST(GlobalMap, RangeLimitsDropNearAndFarPoints) {
  GlobalMapConfig cfg;
  cfg.min_range = 1.0;
  cfg.max_range = 10.0;
  GlobalMap map(cfg);
  LabeledCloud scan;
  scan.push_back({0.5f, 0, 0});
  scan.push_back({5.0f, 0, 0});
  scan.push_back({20.0f, 0, 0});
  scan.push_back({std::nanf(""), 0, 0});
  map.insert(0, scan, Eigen::Isometry3d::Identity());
  EXPECT_EQ(map.size(), 1u);
  EXPECT_EQ(map.pointsInserted(), 1u);
}

TEST(GlobalMap, VoxelCapCoarsensAndKeepsPointsClassesAndFrames) {
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.1;
  cfg.max_voxels = 1000;
  GlobalMap map(cfg);
  // 40 frames, each a fresh 1 m × 1 m floor tile of 100 cells: 4,000 cells uncapped.
  std::size_t heat_points = 0;
  for (int f = 0; f < 40; ++f) {
    LabeledCloud scan;
    scan.enableProperty();
    addPatch(scan, {float(f % 8), float(f / 8)}, 1.0f, 0.1f, 0.0f, kNone);
    if (f == 3) {
      addPatch(scan, {3.2f, 0.2f}, 0.4f, 0.05f, 0.02f, kHeat, 80.0f);
      heat_points = 64;
    }
    map.insert(std::size_t(f), scan, Eigen::Isometry3d::Identity());
    ASSERT_LE(map.size(), cfg.max_voxels) << "frame " << f;
  }
  EXPECT_GE(map.coarsenings(), 1);
  EXPECT_NEAR(map.voxelSize(), 0.1 * std::pow(2.0, map.coarsenings()), 1e-12);
  std::size_t points = 0;
  bool heat_found = false;
  for (const auto& c : map.cells()) {
    points += c.points;
    if (c.label == kHeat) {
      heat_found = true;
      EXPECT_NEAR(c.property_mean, 80.0f, 1e-3);
      ASSERT_EQ(c.frames.size(), 1u);
      EXPECT_EQ(c.frames[0], (FrameRange{3, 3}));
      EXPECT_EQ(c.frame_count, 1u);
    }
  }
  EXPECT_EQ(points, map.pointsInserted());
  EXPECT_EQ(points, 40u * 100u + heat_points);
  EXPECT_TRUE(heat_found) << "the heat patch must survive coarsening";
  // Centroids stay where the points are (in the covered area).
  const AxisAlignedBox b = map.bounds();
  EXPECT_GE(b.min.x(), 0.0f);
  EXPECT_LE(b.max.x(), 8.0f);
}

TEST(GlobalMap, MemoryStaysBoundedOnALongRun) {
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.05;
  cfg.max_voxels = 5000;
  GlobalMap map(cfg);
  std::size_t peak_cells = 0, peak_bytes = 0;
  for (int f = 0; f < 300; ++f) {  // a corridor 300 m long
    LabeledCloud scan;
    addPatch(scan, {0.0f, 0.0f}, 1.0f, 0.05f, 0.0f, kNone);
    map.insert(std::size_t(f), scan, fromXyzRpy(f, 0, 0, 0, 0, 0));
    peak_cells = std::max(peak_cells, map.size());
    peak_bytes = std::max(peak_bytes, map.memoryBytes());
  }
  EXPECT_LE(peak_cells, cfg.max_voxels);
  EXPECT_LT(peak_bytes, 5000u * 256u);
  // The whole corridor is still covered.
  EXPECT_LT(map.bounds().min.x(), 1.0f);
  EXPECT_GT(map.bounds().max.x(), 299.0f);
}

TEST(GlobalMap, FramesSeenBookkeeping) {
  GlobalMapConfig cfg;
  cfg.voxel_size = 1.0;
  cfg.max_frame_ranges = 3;
  GlobalMap map(cfg);
  LabeledCloud heat, plain;
  heat.push_back({0.5f, 0.5f, 0.5f}, kHeat);
  heat.push_back({0.6f, 0.5f, 0.5f}, kHeat);
  plain.push_back({5.5f, 0.5f, 0.5f}, kNone);
  for (std::size_t f : {0, 1, 2, 3, 4, 10, 11, 12}) map.insert(f, heat, Eigen::Isometry3d::Identity());
  for (std::size_t f = 0; f < 13; ++f) map.insert(f, plain, Eigen::Isometry3d::Identity());
  map.insert(7, heat, Eigen::Isometry3d::Identity());  // out of order
  map.insert(7, heat, Eigen::Isometry3d::Identity());  // repeated: counted once
  const auto cells = map.cells();
  ASSERT_EQ(cells.size(), 2u);
  EXPECT_EQ(cells[0].frames, (std::vector<FrameRange>{{0, 4}, {7, 7}, {10, 12}}));
  EXPECT_EQ(cells[0].frame_count, 9u);
  EXPECT_TRUE(cells[1].frames.empty());  // plain cells record no frames
  // A fourth disjoint range exceeds max_frame_ranges = 3: the closest two merge.
  map.insert(20, heat, Eigen::Isometry3d::Identity());
  const auto capped = map.cells()[0].frames;
  EXPECT_EQ(capped, (std::vector<FrameRange>{{0, 7}, {10, 12}, {20, 20}}));
  EXPECT_EQ(map.cells()[0].frame_count, 10u);
  EXPECT_EQ(countFrames(capped), 12u);  // merged ranges over-cover; the count stays exact
}

TEST(GlobalMap, BadInputGivesClearErrors) {
  GlobalMapConfig bad;
  bad.voxel_size = 0;
  EXPECT_THROW(GlobalMap{bad}, Error);
  bad = {};
  bad.max_voxels = 10;
  EXPECT_THROW(GlobalMap{bad}, Error);
  GlobalMap map;
  LabeledCloud scan;
  scan.push_back({1, 1, 1}, 77);  // not in the default table
  try {
    map.insert(4, scan, Eigen::Isometry3d::Identity());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("class 77"), std::string::npos) << e.what();
  }
  scan.classes[0] = kNone;
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan(1, 3) = std::nan("");
  EXPECT_THROW(map.insert(0, scan, nan), Error);
  EXPECT_EQ(map.size(), 0u);
  const GlobalMapConfig y = GlobalMapConfig::fromYamlString("voxel_size: 0.2\nmax_voxels: 5000\n", "map.yaml");
  EXPECT_DOUBLE_EQ(y.voxel_size, 0.2);
  EXPECT_EQ(y.max_voxels, 5000u);
  EXPECT_THROW(GlobalMapConfig::fromYamlString("voxel_sise: 0.2\n", "map.yaml"), Error);
  EXPECT_THROW(GlobalMapConfig::fromYamlString("voxel_size: -1\n", "map.yaml"), Error);
  EXPECT_THROW(GlobalMapConfig::fromYamlString("voxel_size: [\n", "map.yaml"), Error);
}

// ---- hazards -----------------------------------------------------------------------------------

namespace {
GlobalMap patchesMap() {
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.1;
  GlobalMap map(cfg);
  LabeledCloud floor;
  addPatch(floor, {-2.0f, -2.0f}, 8.0f, 0.1f, -0.05f, kNone);  // z in cell -1, below the patches
  for (std::size_t f = 0; f < 6; ++f) {
    LabeledCloud scan = floor;
    scan.enableProperty();
    if (f <= 3) addPatch(scan, {0.0f, 0.0f}, 1.0f, 0.05f, 0.05f, kHeat, 60.0f + float(f));  // 1 m²
    if (f >= 2) addPatch(scan, {3.0f, 0.0f}, 0.5f, 0.05f, 0.05f, kHeat, 40.0f);  // 0.25 m²
    if (f == 5) addPatch(scan, {0.0f, 3.0f}, 2.0f, 0.05f, 0.05f, kWater, 1.0f);  // 4 m² puddle
    if (f == 1) scan.push_back({5.05f, 5.05f, 0.05f}, kRadiation, 0, 0, 9.0f);   // a lone point
    map.insert(f, scan, Eigen::Isometry3d::Identity());
  }
  return map;
}
}  // namespace

TEST(Hazards, ClustersSyntheticPatchesPerClass) {
  const GlobalMap map = patchesMap();
  const std::vector<Hazard> hazards = findHazards(map);
  ASSERT_EQ(hazards.size(), 3u);  // the lone radiation point is noise
  // Order: class id, then size.
  const Hazard& big = hazards[0];
  const Hazard& small = hazards[1];
  const Hazard& puddle = hazards[2];
  EXPECT_EQ(big.label, kHeat);
  EXPECT_EQ(big.kind, PropertyKind::Heat);
  EXPECT_EQ(big.class_name, "heat");
  EXPECT_EQ(big.id, 1);
  EXPECT_NEAR(big.centroid.x(), 0.5, 1e-3);
  EXPECT_NEAR(big.centroid.y(), 0.5, 1e-3);
  EXPECT_NEAR(big.area_m2, 1.0, 1e-9);
  EXPECT_NEAR(big.extent().x(), 1.0, 1e-9);
  EXPECT_NEAR(big.extent().z(), 0.1, 1e-9);
  EXPECT_EQ(big.points, 4u * 400u);
  ASSERT_TRUE(big.mean_property.has_value());
  EXPECT_NEAR(*big.mean_property, 61.5, 1e-3);  // frames 0..3 at 60..63
  EXPECT_EQ(big.frames, (std::vector<FrameRange>{{0, 3}}));
  EXPECT_EQ(big.frame_count, 4u);

  EXPECT_EQ(small.label, kHeat);
  EXPECT_NEAR(small.centroid.x(), 3.25, 1e-3);
  EXPECT_NEAR(small.area_m2, 0.25, 1e-9);
  EXPECT_EQ(small.frames, (std::vector<FrameRange>{{2, 5}}));
  EXPECT_NEAR(*small.mean_property, 40.0, 1e-4);

  EXPECT_EQ(puddle.label, kWater);
  EXPECT_EQ(puddle.kind, PropertyKind::Water);
  EXPECT_NEAR(puddle.area_m2, 4.0, 1e-9);
  EXPECT_EQ(puddle.frame_count, 1u);
  EXPECT_NEAR(puddle.centroid.y(), 4.0, 1e-3);

  // With a looser noise filter the lone point becomes a (radiation) hazard of its own.
  HazardConfig loose;
  loose.min_cells = 1;
  loose.min_points = 1;
  const auto all = findHazards(map, loose);
  ASSERT_EQ(all.size(), 4u);
  EXPECT_EQ(all[3].label, kRadiation);
  EXPECT_EQ(all[3].frames, (std::vector<FrameRange>{{1, 1}}));
}

TEST(Hazards, LinkDistanceBridgesSmallGaps) {
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.1;
  GlobalMap map(cfg);
  LabeledCloud scan;
  addPatch(scan, {0.0f, 0.0f}, 0.3f, 0.05f, 0.05f, kHeat);
  addPatch(scan, {0.4f, 0.0f}, 0.3f, 0.05f, 0.05f, kHeat);  // one empty cell column between
  map.insert(0, scan, Eigen::Isometry3d::Identity());
  HazardConfig tight;
  tight.link_cells = 1;
  EXPECT_EQ(findHazards(map, tight).size(), 2u);
  EXPECT_EQ(findHazards(map).size(), 1u);  // default link_cells = 2 bridges the gap
}

TEST(Hazards, JsonAndCsvFiles) {
  const GlobalMap map = patchesMap();
  const auto hazards = findHazards(map);
  const auto dir = test::scratchDir();
  writeHazardsJson(dir / "hazards.json", hazards, map.voxelSize());
  writeHazardsCsv(dir / "hazards.csv", hazards);
  const auto j = nlohmann::json::parse(readTextFile(dir / "hazards.json"));
  EXPECT_EQ(j["count"], 3);
  ASSERT_EQ(j["hazards"].size(), 3u);
  EXPECT_EQ(j["hazards"][0]["class"], "heat");
  EXPECT_EQ(j["hazards"][2]["kind"], "water");
  EXPECT_NEAR(j["hazards"][0]["area_m2"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(j["hazards"][1]["frames"], nlohmann::json::parse("[[2, 5]]"));
  EXPECT_NEAR(j["hazards"][0]["mean_property"].get<double>(), 61.5, 1e-3);
  std::istringstream csv(readTextFile(dir / "hazards.csv"));
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("id,class,kind,centroid_x", 0), 0u);
  int rows = 0;
  while (std::getline(csv, line)) {
    ++rows;
    if (rows == 2) EXPECT_NE(line.find(",2-5"), std::string::npos) << line;
  }
  EXPECT_EQ(rows, 3);
}

// ---- exports -----------------------------------------------------------------------------------

TEST(MapExport, ColoursByClassAndHeight) {
  const ClassTable table = ClassTable::defaults();
  LabeledCloud c;
  c.push_back({0, 0, 0.0f}, kNone);
  c.push_back({0, 0, 3.0f}, kNone);
  c.push_back({0, 0, 1.0f}, kHeat);
  c.push_back({0, 0, 1.0f}, kWater);
  c.push_back({0, 0, 1.0f}, kRadiation);
  const MapColorConfig cfg;
  const auto colors = mapColors(c, table, cfg);
  EXPECT_EQ(colors[2], cfg.heat);
  EXPECT_EQ(colors[3], cfg.water);
  EXPECT_EQ(colors[4], cfg.radiation);
  EXPECT_EQ(colors[0][0], colors[0][1]);  // grey
  EXPECT_EQ(colors[0][1], colors[0][2]);
  EXPECT_LT(colors[0][0], colors[1][0]);  // higher is lighter
  EXPECT_GT(colors[2][0], 200);
  EXPECT_LT(colors[2][2], 60);  // red
  EXPECT_GT(colors[3][2], 200);  // blue
  EXPECT_GT(colors[4][1], 180);  // yellow
}

TEST(MapExport, PlyAndPcdRoundTrip) {
  const GlobalMap map = patchesMap();
  const LabeledCloud cloud = map.cloud();
  const auto dir = test::scratchDir();
  writeMapPly(dir / "map.ply", cloud, map.classTable());
  writeMapPcd(dir / "map.pcd", cloud);
  const LabeledCloud ply = readPly(dir / "map.ply");
  const LabeledCloud pcd = readPcd(dir / "map.pcd");
  ASSERT_EQ(ply.size(), cloud.size());
  ASSERT_EQ(pcd.size(), cloud.size());
  std::size_t heat = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_EQ(ply.classes[i], cloud.classes[i]);
    EXPECT_EQ(pcd.classes[i], cloud.classes[i]);
    heat += cloud.classes[i] == kHeat;
  }
  EXPECT_GT(heat, 100u);
  const std::string header = readTextFile(dir / "map.ply").substr(0, 400);
  EXPECT_NE(header.find("property uchar red"), std::string::npos);
  EXPECT_NE(readTextFile(dir / "map.pcd").find("label"), std::string::npos);
}

// ---- PNG renders -------------------------------------------------------------------------------

TEST(MapRender, TopDownPngShowsHazardsAndTrajectory) {
  const GlobalMap map = patchesMap();
  const auto hazards = findHazards(map);
  std::vector<Eigen::Vector3d> traj;
  for (int i = 0; i <= 20; ++i) traj.emplace_back(-1.5 + 0.3 * i, -1.0, 0.0);
  TopDownConfig cfg;
  cfg.pixels_per_metre = 40;
  cfg.title = "test map";
  cfg.cell_size = map.voxelSize();
  TopDownFrame frame;
  const Image img = renderTopDown(map.cloud(), map.classTable(), traj, hazards, cfg, &frame);
  const auto dir = test::scratchDir();
  writePng(dir / "map_top.png", img);
  const Decoded d = readPngBack(dir / "map_top.png");
  ASSERT_EQ(d.w, img.width);
  ASSERT_EQ(d.h, img.height);
  EXPECT_GT(img.width, 8 * 40);
  // Heat red, water blue and the purple trajectory are all there; the heat patch (1 m² at
  // 40 px/m) covers on the order of 1600 pixels.
  EXPECT_GT(countColor(d, cfg.colors.heat), 1000u);
  EXPECT_GT(countColor(d, cfg.colors.water), 3000u);
  EXPECT_GT(countColor(d, cfg.trajectory), 100u);
  // The lone radiation point is no hazard: drawn like a plain cell unless asked otherwise.
  EXPECT_EQ(countColor(d, cfg.colors.radiation), 0u);
  TopDownConfig all_cells = cfg;
  all_cells.hazard_cells_only = false;
  const Image speckled = renderTopDown(map.cloud(), map.classTable(), traj, hazards, all_cells);
  writePng(dir / "speckled.png", speckled);
  EXPECT_GT(countColor(readPngBack(dir / "speckled.png"), cfg.colors.radiation), 0u);
  // The pixel at the heat patch centre is heat red, and the frame maps metres to pixels at the
  // requested scale.
  EXPECT_DOUBLE_EQ(frame.pixels_per_metre, 40.0);
  const Eigen::Vector2d heat = frame.pixelOf(0.5, 0.5);
  EXPECT_EQ(d.at(int(heat.x()), int(heat.y())), cfg.colors.heat);
  const Eigen::Vector2d puddle = frame.pixelOf(1.0, 4.0);
  EXPECT_EQ(d.at(int(puddle.x()), int(puddle.y())), cfg.colors.water);
  // Text, axes and the legend are drawn in dark anti-aliased strokes (real glyphs, not blocks).
  std::size_t dark = 0, midtone = 0;
  for (int y = 0; y < d.h; ++y)
    for (int x = 0; x < d.w; ++x) {
      const Rgb c = d.at(x, y);
      dark += c[0] < 60 && c[1] < 60 && c[2] < 60;
      midtone += c[0] == c[1] && c[1] == c[2] && c[0] > 60 && c[0] < 200 && int(y) < int(frame.origin.y());
    }
  EXPECT_GT(dark, 300u);
  EXPECT_GT(midtone, 20u);  // anti-aliased title edges above the map
}

TEST(MapRender, TrajectoryComparisonAndMontagePngs) {
  Trajectory gt, est, odom;
  for (int i = 0; i < 100; ++i) {
    const double a = 0.06 * i;
    gt.push_back(i, fromXyYaw(10 * std::cos(a), 10 * std::sin(a), a));
    est.push_back(i, fromXyYaw(10.2 * std::cos(a), 10.2 * std::sin(a), a));
    odom.push_back(i, fromXyYaw(11 * std::cos(a) + 0.01 * i, 11 * std::sin(a), a));
  }
  const auto dir = test::scratchDir();
  const Image plot = renderTrajectoryComparison(est, &gt, &odom);
  writePng(dir / "trajectory.png", plot);
  const Decoded d = readPngBack(dir / "trajectory.png");
  ASSERT_EQ(d.w, 1400);
  ASSERT_EQ(d.h, 700);
  const Rgb blue{20, 80, 220}, orange{240, 140, 0};
  EXPECT_GT(countColor(d, blue), 500u);
  EXPECT_GT(countColor(d, orange), 500u);
  EXPECT_GT(countColor(d, {0, 0, 0}), 500u);  // ground truth, text, axes
  // Without ground truth: one panel, no error plot, still fine.
  EXPECT_NO_THROW(renderTrajectoryComparison(est, nullptr, &odom));
  Trajectory shorter = gt;
  shorter.poses.pop_back();
  shorter.stamps.pop_back();
  EXPECT_THROW(renderTrajectoryComparison(est, &shorter, nullptr), Error);

  // Five maps side by side with titles, one shared view.
  const GlobalMap map = patchesMap();
  const LabeledCloud cloud = map.cloud();
  std::vector<MapPanel> panels;
  for (const char* name : {"odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo"})
    panels.push_back({name, &cloud, positionsOf(gt), {}});
  TopDownConfig cfg;
  cfg.max_size_px = 300;
  const Image montage = renderMapMontage(panels, map.classTable(), cfg, {});
  writePng(dir / "maps.png", montage);
  const Decoded m = readPngBack(dir / "maps.png");
  ASSERT_EQ(m.w, montage.width);
  EXPECT_GT(m.w, 3 * 250);  // three per row
  EXPECT_GT(m.h, 2 * 250);  // two rows
  EXPECT_GT(countColor(m, cfg.colors.heat), 5u * 50u);
}

TEST(MapRender, ErrorPlotAndBadInput) {
  // Two methods' error against distance: both curves and the legend are drawn.
  std::vector<ErrorSeries> series(2);
  for (int i = 0; i < 50; ++i) {
    series[0].distance_m.push_back(i);
    series[0].error_m.push_back(0.01 * i);
    series[1].distance_m.push_back(i);
    series[1].error_m.push_back(0.2 + 0.002 * i);
  }
  series[0].label = "icp";
  series[0].color = seriesColor(0);
  series[1].label = "property-icp";
  series[1].color = seriesColor(1);
  const Image plot = renderErrorPlot(series);
  EXPECT_EQ(plot.width, 1200);
  std::size_t first = 0, second = 0;
  for (int y = 0; y < plot.height; ++y)
    for (int x = 0; x < plot.width; ++x) {
      first += plot.get(x, y) == seriesColor(0);
      second += plot.get(x, y) == seriesColor(1);
    }
  EXPECT_GT(first, 500u);
  EXPECT_GT(second, 500u);
  series[1].error_m.pop_back();
  EXPECT_THROW(renderErrorPlot(series), Error);
  EXPECT_THROW(renderErrorPlot({}), Error);
  EXPECT_EQ(distanceTravelled(Trajectory{}).size(), 0u);
  Image img(200, 50);
  const auto dir = test::scratchDir();
  EXPECT_THROW(writePng(dir / "missing" / "x.png", img), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "missing"));
  EXPECT_THROW(writePng(dir / "empty.png", Image{}), Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "empty.png"));
  EXPECT_THROW(renderMontage({}), Error);
  // An empty map still renders (blank with the trajectory) instead of failing.
  const Image blank = renderTopDown(LabeledCloud{}, ClassTable::defaults(), {});
  EXPECT_FALSE(blank.empty());
}

TEST(MapRender, EvalPlotDrawsEveryEstimateAgainstDistance) {
  const auto dir = test::scratchDir();
  Trajectory gt, a, b;
  for (int i = 0; i < 80; ++i) {
    const double t = 0.05 * i;
    gt.push_back(i, fromXyYaw(20 * std::cos(t), 10 * std::sin(t), t));
    a.push_back(i, fromXyYaw(20 * std::cos(t) + 0.01 * i, 10 * std::sin(t), t));
    b.push_back(i, fromXyYaw(20 * std::cos(t), 10 * std::sin(t) - 0.02 * i, t));
  }
  std::filesystem::create_directories(dir / "icp");
  std::filesystem::create_directories(dir / "property-icp");
  writeKittiTrajectory(dir / "gt.kitti", gt);
  writeKittiTrajectory(dir / "icp" / "trajectory.kitti", a);
  writeKittiTrajectory(dir / "property-icp" / "trajectory.kitti", b);
  const std::string args = "eval --gt " + (dir / "gt.kitti").string() + " --est " + (dir / "icp/trajectory.kitti").string() +
                           " --compare " + (dir / "property-icp/trajectory.kitti").string();
  const auto r = test::runCli(args + " --plot " + (dir / "errors.png").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Decoded d = readPngBack(dir / "errors.png");
  ASSERT_EQ(d.w, 1200);
  EXPECT_GT(countColor(d, seriesColor(0)), 300u);
  EXPECT_GT(countColor(d, seriesColor(1)), 300u);
  EXPECT_NE(test::runCli(args).exit_code, 0);  // --compare draws only on a --plot
  EXPECT_NE(test::runCli(args + " --plot " + (dir / "missing/errors.png").string()).exit_code, 0);
}

// ---- real data ---------------------------------------------------------------------------------

TEST(GlobalMapReal, SemanticKittiScanGivesPoleSignTrunkHazards) {
  const ClassTable table = ClassTable::semanticKitti();
  const auto dir = test::sharedData("kitti-semantic-sample");
  GlobalMapConfig cfg;
  cfg.voxel_size = 0.2;
  GlobalMap map(cfg, table);
  const LabeledCloud scan =
      readKittiScan(dir / "velodyne/000000.bin", dir / "labels/000000.label", table);
  std::size_t labelled = 0;
  for (ClassId c : scan.classes) labelled += table.isProperty(c);
  ASSERT_GT(labelled, 100u);
  map.insert(0, scan, Eigen::Isometry3d::Identity());
  const auto hazards = findHazards(map);
  ASSERT_FALSE(hazards.empty());
  std::size_t poles = 0;
  for (const auto& h : hazards) {
    EXPECT_TRUE(table.isProperty(h.label));
    EXPECT_EQ(h.frames, (std::vector<FrameRange>{{0, 0}}));
    poles += h.label == 1;  // pole → heat
    // Poles, signs and trunks are compact: no region is larger than a few metres across.
    EXPECT_LT(std::max(h.extent().x(), h.extent().y()), 15.0) << h.class_name << " #" << h.id;
  }
  EXPECT_GE(poles, 2u);
  const auto out = test::scratchDir();
  writeHazardsJson(out / "hazards.json", hazards, map.voxelSize());
  writePng(out / "map_top.png", renderTopDown(map.cloud(), table, {{0, 0, 0}}, hazards));
  EXPECT_GT(std::filesystem::file_size(out / "map_top.png"), 1000u);
}

TEST(MapOutputs, WritesEveryFileAtomically) {
  const GlobalMap map = patchesMap();
  Trajectory est, gt;
  for (int i = 0; i < 6; ++i) {
    gt.push_back(i, fromXyYaw(-1.0 + i, -1.0, 0.0));
    est.push_back(i, fromXyYaw(-1.0 + i, -1.0 + 0.02 * i, 0.0));
  }
  const auto dir = test::scratchDir();
  const MapOutputs out = writeMapOutputs(dir, map, est, &gt, nullptr);
  EXPECT_EQ(out.hazards.size(), 3u);
  for (const char* name : {"map.ply", "map.pcd", "hazards.json", "hazards.csv", "map_top.png", "trajectory.png"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir / name)) << name;
  EXPECT_EQ(out.files.size(), 6u);
  const Decoded top = readPngBack(dir / "map_top.png");
  EXPECT_GT(top.w, 0);
  // No temporary files are left behind.
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    EXPECT_NE(entry.path().filename().string()[0], '.') << entry.path();
  EXPECT_THROW(writeMapOutputs(dir / "nope", map, est), Error);
}
