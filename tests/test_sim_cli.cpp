// `hazmap simulate`: the sequence directory it writes (readable by hazmap::Sequence), same seed →
// same bytes, the reference map from poses.txt is sharp while the odometry map is not, and bad
// configuration fails before anything is written.
#include <gtest/gtest.h>

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/sim/mesh_builder.hpp"
#include "hazmap/sim/scene.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/core/error.hpp"
#include "test_helpers.hpp"

namespace fs = std::filesystem;
using namespace hazmap;
using hazmap::test::runCli;
using hazmap::test::scratchDir;

namespace {

std::string bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<fs::path> filesUnder(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out.push_back(fs::relative(e.path(), dir));
  std::sort(out.begin(), out.end());
  return out;
}

/// simulation.yaml's world_from_first_frame: maps poses.txt / reference_map.ply to the scene.
Eigen::Isometry3d worldFromFirst(const fs::path& seq) {
  const YAML::Node n = YAML::LoadFile((seq / "simulation.yaml").string())["world_from_first_frame"];
  EXPECT_TRUE(n && n.size() == 12);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) T.linear()(r, k) = n[4 * r + k].as<double>();
    T.translation()(r) = n[4 * r + 3].as<double>();
  }
  return T;
}

/// RMS and 99th-percentile distance to the plane y = y0 of the given world points.
std::pair<double, double> planeSpread(const std::vector<Eigen::Vector3d>& pts, double y0) {
  std::vector<double> d;
  double ss = 0.0;
  for (const auto& p : pts) {
    d.push_back(std::abs(p.y() - y0));
    ss += d.back() * d.back();
  }
  std::sort(d.begin(), d.end());
  return {std::sqrt(ss / d.size()), d[static_cast<std::size_t>(0.99 * (d.size() - 1))]};
}

}  // namespace

TEST(SimCli, WritesAReadableSequence) {
  const fs::path out = scratchDir() / "seq";
  const auto r = runCli("simulate --scenario naraha --frames 4 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("4 frames"), std::string::npos) << r.output;
  for (const char* f : {"poses.txt", "odometry.txt", "times.txt", "hazmap.yaml", "reference_map.ply",
                        "scene.ply", "simulation.yaml", "velodyne/000003.bin", "labels/000003.label"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_FALSE(fs::exists(out / "velodyne/000004.bin"));
  const Sequence seq = Sequence::open(out);
  ASSERT_EQ(seq.size(), 4u);
  ASSERT_TRUE(seq.groundTruth() && seq.odometry());
  ASSERT_EQ(seq.groundTruth()->size(), 4u);
  EXPECT_TRUE(seq.groundTruth()->poses[0].isApprox(seq.odometry()->poses[0], 1e-12));
  // KITTI convention: poses in the first scan's frame; simulation.yaml says where that is.
  EXPECT_TRUE(seq.groundTruth()->poses[0].isApprox(Eigen::Isometry3d::Identity(), 1e-12));
  const Eigen::Isometry3d W = worldFromFirst(out);
  EXPECT_TRUE(W.translation().isApprox(Eigen::Vector3d(5.0, 2.5, 0.5), 1e-12));  // naraha start, mount height
  EXPECT_NE(seq.sensorYaml().find("elevations_deg"), std::string::npos);
  const LabeledCloud scan = seq.frame(0);
  EXPECT_GT(scan.size(), 20000u);
  EXPECT_LT(scan.size(), 28800u);
  // The scene mesh carries per-face classes and the reference map has heat and water points.
  const TriangleMesh scene = readPlyMesh(out / "scene.ply");
  ASSERT_EQ(scene.triangle_classes.size(), scene.triangles.size());
  EXPECT_GT(std::count(scene.triangle_classes.begin(), scene.triangle_classes.end(), 1), 0);
  const LabeledCloud map = readPly(out / "reference_map.ply");
  EXPECT_GT(map.size(), 10000u);
  EXPECT_GT(std::count(map.classes.begin(), map.classes.end(), 1), 0);  // the corridor heater
  // The reference map is ground truth: its classes carry no label noise. Every labelled map
  // point (a voxel centroid) lies within a voxel of a region of its class.
  const sim::Scene naraha = sim::builtinScene("naraha");
  std::size_t labelled = 0;
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (map.classes[i] == 0) continue;
    ++labelled;
    bool found = false;
    for (int dx = -1; dx <= 1 && !found; ++dx)
      for (int dy = -1; dy <= 1 && !found; ++dy)
        for (int dz = -1; dz <= 1 && !found; ++dz)
          found = naraha.classAt(W * map.points[i].cast<double>() + 0.1 * Eigen::Vector3d(dx, dy, dz)) == map.classes[i];
    EXPECT_TRUE(found) << "map point " << map.points[i].transpose() << " class " << map.classes[i];
  }
  EXPECT_GT(labelled, 50u);
}

TEST(SimCli, SameSeedSameBytesDifferentSeedDifferentScans) {
  const fs::path dir = scratchDir();
  ASSERT_EQ(runCli("simulate --scenario tanks --frames 3 --seed 5 --out " + (dir / "a").string()).exit_code, 0);
  ASSERT_EQ(runCli("simulate --scenario tanks --frames 3 --seed 5 --out " + (dir / "b").string()).exit_code, 0);
  ASSERT_EQ(runCli("simulate --scenario tanks --frames 3 --seed 6 --out " + (dir / "c").string()).exit_code, 0);
  const auto files = filesUnder(dir / "a");
  ASSERT_EQ(files, filesUnder(dir / "b"));
  for (const auto& f : files) EXPECT_EQ(bytes(dir / "a" / f), bytes(dir / "b" / f)) << f;
  EXPECT_NE(bytes(dir / "a/velodyne/000001.bin"), bytes(dir / "c/velodyne/000001.bin"));
  EXPECT_NE(bytes(dir / "a/odometry.txt"), bytes(dir / "c/odometry.txt"));
  EXPECT_EQ(bytes(dir / "a/poses.txt"), bytes(dir / "c/poses.txt"));  // the route is the route
}

TEST(SimCli, ReferenceMapFromPosesIsSharpOdometryMapIsNot) {
  // Straight down the featureless corridor: its walls are the planes y = ±1.5.
  const fs::path out = scratchDir() / "corridor";
  ASSERT_EQ(runCli("simulate --scenario corridor --frames 14 --seed 3 --out " + out.string()).exit_code, 0);
  const Sequence seq = Sequence::open(out);
  const Eigen::Isometry3d W = worldFromFirst(out);
  std::vector<Eigen::Vector3d> truth_wall, odo_wall;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    const LabeledCloud scan = seq.frame(i);
    const Eigen::Isometry3d T = W * seq.groundTruth()->poses[i];
    const Eigen::Isometry3d O = W * seq.odometry()->poses[i];
    for (const auto& p : scan.points) {
      const Eigen::Vector3d w = T * p.cast<double>();
      // North-wall points by their true position (away from floor, ceiling and panels).
      if (std::abs(w.y() - 1.5) < 0.2 && w.z() > 1.6 && w.z() < 2.8 && w.x() > 2 && w.x() < 58) {
        truth_wall.push_back(w);
        odo_wall.push_back(O * p.cast<double>());
      }
    }
  }
  ASSERT_GT(truth_wall.size(), 5000u);
  const auto [truth_rms, truth_p99] = planeSpread(truth_wall, 1.5);
  const auto [odo_rms, odo_p99] = planeSpread(odo_wall, 1.5);
  std::printf("wall spread: truth rms %.4f p99 %.4f, odometry rms %.4f p99 %.4f\n", truth_rms, truth_p99, odo_rms, odo_p99);
  EXPECT_LT(truth_rms, 0.035);  // range noise σ = 0.03 m, mostly along the wall normal
  EXPECT_LT(truth_p99, 0.10);
  EXPECT_GT(odo_rms, 2.0 * truth_rms) << "odometry map rms " << odo_rms;
  EXPECT_GT(odo_p99, 0.10);
}

TEST(SimCli, BadConfigurationFailsBeforeWritingAnything) {
  const fs::path dir = scratchDir();
  const fs::path out = dir / "never";
  auto expectFailure = [&](const std::string& args, const std::string& message) {
    const auto r = runCli("simulate --out " + out.string() + " " + args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    EXPECT_FALSE(fs::exists(out)) << args;
    for (const auto& e : fs::directory_iterator(dir))
      EXPECT_EQ(e.path().filename().string().find(".never.partial"), std::string::npos);
  };
  writeTextAtomically(dir / "neg.yaml", "sensor: {range_noise_sigma: -0.03}\n");
  expectFailure("--config " + (dir / "neg.yaml").string(), "sensor.range_noise_sigma: must be >= 0");
  writeTextAtomically(dir / "negodo.yaml", "odometry: {forward_scale_sigma: -0.05}\n");
  expectFailure("--config " + (dir / "negodo.yaml").string(), "odometry.forward_scale_sigma: must be >= 0");
  expectFailure("--scenario atlantis", "unknown scenario 'atlantis'");

  TriangleMesh empty;
  writePlyMesh(dir / "empty.ply", empty);
  writeTextAtomically(dir / "regions.yaml", "route: {waypoints: [[0, 0], [5, 0]]}\n");
  expectFailure("--scene " + (dir / "empty.ply").string() + " --regions " + (dir / "regions.yaml").string(),
                "scene mesh is empty");

  TriangleMesh room;
  sim::MeshBuilder(room).box({-5, -5, -0.1}, {5, 5, 0});
  writePlyMesh(dir / "room.ply", room);
  writeTextAtomically(dir / "alien.yaml",
                      "regions: [{name: goo, class: plasma, box: {min: [0, 0, 0], max: [1, 1, 1]}}]\n"
                      "route: {waypoints: [[0, 0], [2, 0]]}\n");
  expectFailure("--scene " + (dir / "room.ply").string() + " --regions " + (dir / "alien.yaml").string(),
                "region 'goo' has unknown class 'plasma'");
  {
    const auto neg = runCli("simulate --scenario corridor --frames -1 --out " + out.string());
    EXPECT_NE(neg.exit_code, 0);
    EXPECT_NE(neg.output.find("--frames"), std::string::npos) << neg.output;
    EXPECT_FALSE(fs::exists(out));
  }
  // An existing, non-empty folder is never replaced unless it is a sequence and --overwrite is
  // given.
  fs::create_directories(out);
  writeTextAtomically(out / "keep.txt", "mine");
  auto r = runCli("simulate --scenario corridor --frames 2 --out " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("not empty"), std::string::npos);
  r = runCli("simulate --scenario corridor --frames 2 --overwrite --out " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("is not a hazmap sequence"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(out / "keep.txt"));
  const fs::path seq = dir / "seq";
  ASSERT_EQ(runCli("simulate --scenario corridor --frames 4 --out " + seq.string() + "/").exit_code, 0);
  EXPECT_TRUE(fs::exists(seq / "velodyne/000003.bin"));
  ASSERT_EQ(runCli("simulate --scenario corridor --frames 2 --overwrite --out " + seq.string()).exit_code, 0);
  EXPECT_TRUE(fs::exists(seq / "velodyne/000001.bin"));
  EXPECT_FALSE(fs::exists(seq / "velodyne/000003.bin"));  // no stale frames from the last run
  // seq/velodyne/.. is seq itself.
  r = runCli("simulate --scenario corridor --frames 3 --overwrite --out " + seq.string() + "/velodyne/..");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(fs::exists(seq / "velodyne/000002.bin"));
}

TEST(SimCli, NeverReplacesTheCurrentFolder) {
  // Even a folder that looks like a sequence is not replaced when it is (or contains) the
  // current folder.
  const fs::path victim = scratchDir() / "victim";
  fs::create_directories(victim / "velodyne");
  writeTextAtomically(victim / "hazmap.yaml", "frames: 0\n");
  const fs::path before = fs::current_path();
  sim::SimulatorConfig config;
  config.scenario = "corridor";
  config.max_frames = 1;
  fs::current_path(victim / "velodyne");
  std::string message;
  try {
    sim::writeSimulation(config, "..", /*overwrite=*/true);
  } catch (const Error& e) {
    message = e.what();
  }
  fs::current_path(before);
  EXPECT_NE(message.find("current folder"), std::string::npos) << message;
  EXPECT_TRUE(fs::exists(victim / "hazmap.yaml"));
}

TEST(SimCli, UserSceneWithRegionsAndTemperature) {
  const fs::path dir = scratchDir();
  TriangleMesh room;
  sim::MeshBuilder mb(room);
  mb.floorRect(-8, -8, 8, 8, 0.0);
  mb.box({8, -8, 0}, {8.3, 8, 3});
  mb.box({-8.3, -8, 0}, {-8, 8, 3});
  mb.box({-8, 8, 0}, {8, 8.3, 3});
  mb.box({-8, -8.3, 0}, {8, -8, 3});
  writePlyMesh(dir / "room.ply", room);
  writeTextAtomically(dir / "room.yaml",
                      "regions:\n"
                      "  - {name: radiator, class: heat, box: {min: [7.9, -2, 0], max: [8.1, 2, 2]}}\n"
                      "  - {name: leak, class: water, polygon: [[-3, -1], [-1, -2], [-1, 1]], z: [-0.05, 0.05]}\n"
                      "route: {waypoints: [[-4, 0], [4, 0], [4, 4]], corner_radius: 1.0}\n");
  const fs::path out = dir / "seq";
  const auto r = runCli("simulate --scene " + (dir / "room.ply").string() + " --regions " +
                        (dir / "room.yaml").string() + " --temperature --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Sequence seq = Sequence::open(out);
  ASSERT_GE(seq.size(), 10u);
  const LabeledCloud scan = seq.frame(0);
  EXPECT_GT(std::count(scan.classes.begin(), scan.classes.end(), 1), 100);
  // temperature/*.bin: one float per point, hot on the radiator.
  const std::string t = bytes(out / "temperature/000000.bin");
  ASSERT_EQ(t.size(), scan.size() * sizeof(float));
  std::vector<float> temp(scan.size());
  std::memcpy(temp.data(), t.data(), t.size());
  double hot = 0.0, cold = 0.0;
  std::size_t nh = 0, nc = 0;
  for (std::size_t i = 0; i < scan.size(); ++i)
    if (scan.classes[i] == 1) hot += temp[i], ++nh;
    else if (scan.classes[i] == 0) cold += temp[i], ++nc;
  EXPECT_GT(hot / nh, 50.0);
  EXPECT_LT(cold / nc, 25.0);
  // hazmap.yaml names it the sequence's property channel: a run reads it (issue 34: a hotter
  // source is then observable end to end).
  EXPECT_EQ(seq.propertyChannel(), "temperature");
  ASSERT_EQ(scan.property.size(), scan.size());
  EXPECT_EQ(scan.property, temp);
}

TEST(SimCli, SceneAndRegionsFilesReproduceTheBuiltinScene) {
  const fs::path dir = scratchDir();
  ASSERT_EQ(runCli("simulate --scenario naraha --frames 3 --out " + (dir / "a").string()).exit_code, 0);
  ASSERT_TRUE(fs::exists(dir / "a/regions.yaml"));
  const auto r = runCli("simulate --scene " + (dir / "a/scene.ply").string() + " --regions " +
                        (dir / "a/regions.yaml").string() + " --frames 3 --out " + (dir / "b").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(bytes(dir / "a/poses.txt"), bytes(dir / "b/poses.txt"));
  EXPECT_EQ(bytes(dir / "a/odometry.txt"), bytes(dir / "b/odometry.txt"));
  const Sequence a = Sequence::open(dir / "a"), b = Sequence::open(dir / "b");
  for (std::size_t i = 0; i < a.size(); ++i) {
    const LabeledCloud sa = a.frame(i), sb = b.frame(i);
    ASSERT_EQ(sa.size(), sb.size());
    std::size_t label_diff = 0;
    for (std::size_t k = 0; k < sa.size(); ++k) {
      EXPECT_LT((sa.points[k] - sb.points[k]).norm(), 1e-3f);
      label_diff += sa.classes[k] != sb.classes[k];
    }
    EXPECT_LE(label_diff, sa.size() / 10000);
  }
}
