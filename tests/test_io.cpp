// io: the real shared data loads with known counts and values; every format round-trips.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <random>

#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/keyframe_spill.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/io/trajectory.hpp"
#include "io/io_detail.hpp"
#include "test_helpers.hpp"

using namespace hazmap;
namespace fs = std::filesystem;

namespace {

const fs::path kKitti = "kitti-semantic-sample";

std::size_t countClass(const LabeledCloud& c, ClassId id) {
  return static_cast<std::size_t>(std::count(c.classes.begin(), c.classes.end(), id));
}

/// A cloud with every channel, including a few awkward values.
LabeledCloud richCloud(std::size_t n, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-80.0f, 80.0f);
  LabeledCloud c;
  c.enableIntensity();
  c.enableTimestamps();
  c.enableProperty();
  for (std::size_t i = 0; i < n; ++i)
    c.push_back({u(rng), u(rng), u(rng) * 0.1f}, ClassId(i % 4), std::abs(u(rng)) / 80.0f,
                1.6e9 + double(i) * 1e-5, 20.0f + u(rng));
  c.points[0] = {1e-30f, -3.4e38f, 0.1f};  // extreme but finite floats must survive text formats
  return c;
}

void expectSameCloud(const LabeledCloud& a, const LabeledCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.points[i], b.points[i]) << "point " << i;
    ASSERT_EQ(a.classes[i], b.classes[i]) << "point " << i;
  }
  EXPECT_EQ(a.intensity, b.intensity);
  EXPECT_EQ(a.timestamps, b.timestamps);
  EXPECT_EQ(a.property, b.property);
}

}  // namespace

// ---- real data ---------------------------------------------------------------------------------

TEST(IoRealData, SixKittiScansHaveTheirPointCounts) {
  const std::size_t expected[6] = {124668, 124605, 124478, 124167, 123969, 123924};
  for (int i = 0; i < 6; ++i) {
    ReadStats stats;
    char name[32];
    std::snprintf(name, sizeof name, "velodyne/%06d.bin", i);
    const auto cloud = readKittiBin(test::sharedData(kKitti / name), &stats);
    EXPECT_EQ(cloud.size(), expected[i]) << name;
    EXPECT_EQ(stats.points_in_file, expected[i]);
    EXPECT_EQ(stats.dropped_non_finite, 0u);
    EXPECT_EQ(cloud.intensity.size(), cloud.size());
  }
}

TEST(IoRealData, KittiScanKnownValues) {
  const auto c = readKittiBin(test::sharedData(kKitti / "velodyne/000000.bin"));
  ASSERT_EQ(c.size(), 124668u);
  EXPECT_FLOAT_EQ(c.points[0].x(), 52.89794158935547f);
  EXPECT_FLOAT_EQ(c.points[0].y(), 0.02298973873257637f);
  EXPECT_FLOAT_EQ(c.points[0].z(), 1.9979945421218872f);
  EXPECT_FLOAT_EQ(c.intensity[0], 0.08f);
  EXPECT_FLOAT_EQ(c.points.back().x(), 4.0923752784729f);
  EXPECT_FLOAT_EQ(c.points.back().z(), -1.8955610990524292f);
  EXPECT_TRUE(std::all_of(c.classes.begin(), c.classes.end(), [](ClassId k) { return k == 0; }));
}

TEST(IoRealData, SemanticKittiLabelsMapToPropertyClasses) {
  const auto raw = readSemanticKittiLabels(test::sharedData(kKitti / "labels/000000.label"));
  ASSERT_EQ(raw.size(), 124668u);
  std::size_t poles = 0;
  for (auto l : raw) poles += (l & 0xFFFF) == 80;
  EXPECT_EQ(poles, 532u);

  const auto c = readKittiScan(test::sharedData(kKitti / "velodyne/000000.bin"),
                               test::sharedData(kKitti / "labels/000000.label"), ClassTable::semanticKitti());
  ASSERT_EQ(c.size(), 124668u);
  EXPECT_EQ(countClass(c, 1), 532u);   // pole → heat
  EXPECT_EQ(countClass(c, 2), 1192u);  // trunk → water
  EXPECT_EQ(countClass(c, 3), 102u);   // traffic-sign → radiation
  EXPECT_EQ(countClass(c, 0), 124668u - 532u - 1192u - 102u);

  // Frame 2 has different counts: the labels really are per scan.
  const auto c2 = readKittiScan(test::sharedData(kKitti / "velodyne/000002.bin"),
                                test::sharedData(kKitti / "labels/000002.label"), ClassTable::semanticKitti());
  EXPECT_EQ(countClass(c2, 1), 665u);
  EXPECT_EQ(countClass(c2, 2), 1251u);
  EXPECT_EQ(countClass(c2, 3), 93u);
}

TEST(IoRealData, ReadCloudFindsSiblingLabelsFolder) {
  const auto c = readCloud(test::sharedData(kKitti / "velodyne/000001.bin"), ClassTable::semanticKitti());
  EXPECT_EQ(c.size(), 124605u);
  EXPECT_EQ(countClass(c, 1), 585u);
  // Frame 3 has no labels: all class 0.
  const auto c3 = readCloud(test::sharedData(kKitti / "velodyne/000003.bin"), ClassTable::semanticKitti());
  EXPECT_EQ(c3.size(), 124167u);
  EXPECT_EQ(countClass(c3, 0), c3.size());
}

TEST(IoRealData, ScanPairBinaryPcds) {
  ReadStats st;
  const auto target = readPcd(test::sharedData("scan-pair/251370668.pcd"), ClassTable::defaults(), &st);
  EXPECT_EQ(target.size(), 69088u);
  EXPECT_EQ(st.points_in_file, 69088u);
  ASSERT_TRUE(target.hasIntensity());
  EXPECT_FLOAT_EQ(target.points[0].x(), 0.0031398916617035866f);
  EXPECT_FLOAT_EQ(target.points[0].y(), 2.570034980773926f);
  EXPECT_FLOAT_EQ(target.points[0].z(), -1.5241568088531494f);
  EXPECT_FLOAT_EQ(target.intensity[0], 68.0f);
  EXPECT_FLOAT_EQ(target.points.back().y(), 1.9261064529418945f);
  EXPECT_FLOAT_EQ(target.intensity.back(), 36.0f);
  const auto source = readCloud(test::sharedData("scan-pair/251371071.pcd"));
  EXPECT_EQ(source.size(), 69792u);
  EXPECT_FLOAT_EQ(source.intensity[0], 70.0f);
}

TEST(IoRealData, KittiSampleIsASequence) {
  const auto seq = Sequence::open(test::sharedData(kKitti), ClassTable::semanticKitti());
  ASSERT_EQ(seq.size(), 6u);
  EXPECT_EQ(seq.scanPath(5).filename(), "000005.bin");
  EXPECT_FALSE(seq.groundTruth());
  EXPECT_FALSE(seq.odometry());
  ReadStats st;
  const auto f0 = seq.frame(0, &st);
  EXPECT_EQ(f0.size(), 124668u);
  EXPECT_EQ(st.points_in_file, 124668u);
  EXPECT_EQ(countClass(f0, 3), 102u);
  const auto f4 = seq.frame(4);
  EXPECT_EQ(f4.size(), 123969u);
  EXPECT_EQ(countClass(f4, 0), f4.size());
  EXPECT_THROW(seq.frame(6), Error);
}

// A SemanticKITTI folder names no class table: its labels (71 trunk, 80 pole, …) are read with
// the built-in semantic-kitti table, and the sequence says why (one line, for a notice).
TEST(IoRealData, KittiSampleWithoutATableIsReadAsSemanticKitti) {
  const auto seq = Sequence::open(test::sharedData(kKitti));
  EXPECT_NE(seq.tableNote().find("000000.label"), std::string::npos) << seq.tableNote();
  EXPECT_NE(seq.tableNote().find("semantic-kitti"), std::string::npos) << seq.tableNote();
  EXPECT_EQ(seq.tableNote().find('\n'), std::string::npos);
  const auto named = Sequence::open(test::sharedData(kKitti), ClassTable::semanticKitti());
  EXPECT_TRUE(named.tableNote().empty());
  EXPECT_EQ(seq.frame(0).classes, named.frame(0).classes);
  EXPECT_EQ(countClass(seq.frame(0), 3), 102u);  // traffic-sign → radiation
  // A table named on the command line wins: the raw ids are kept, as before.
  const auto plain = Sequence::open(test::sharedData(kKitti), ClassTable::defaults());
  EXPECT_TRUE(plain.tableNote().empty());
  EXPECT_GT(countClass(plain.frame(0), 71), 0u);
}

TEST(IoRealData, KittiGroundTruthTrajectory) {
  const auto t = readTrajectoryAuto(test::sharedData("trajectories/KITTI_00_gt.txt"));
  ASSERT_EQ(t.size(), 4541u);
  EXPECT_NEAR(t.poses[0].translation().norm(), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(t.poses.back().translation().x(), -5.583931);
  EXPECT_DOUBLE_EQ(t.poses.back().translation().z(), 96.96153);
  EXPECT_DOUBLE_EQ(t.poses.back().linear()(0, 1), -9.331753e-03);
  EXPECT_DOUBLE_EQ(t.stamps[10], 10.0);
}

// ---- round trips -------------------------------------------------------------------------------

TEST(IoRoundTrip, KittiBinAndLabels) {
  const auto dir = test::scratchDir();
  LabeledCloud c = richCloud(500);
  writeCloud(dir / "a.bin", c);
  ASSERT_TRUE(fs::exists(dir / "a.label"));
  const auto back = readCloud(dir / "a.bin");
  ASSERT_EQ(back.size(), c.size());
  EXPECT_EQ(back.points, c.points);
  EXPECT_EQ(back.classes, c.classes);
  EXPECT_EQ(back.intensity, c.intensity);
  EXPECT_FALSE(back.hasTimestamps());  // .bin has no time channel

  // All-zero classes: no .label written.
  LabeledCloud plain = readKittiBin(dir / "a.bin");
  writeCloud(dir / "b.bin", plain);
  EXPECT_FALSE(fs::exists(dir / "b.label"));
}

// Keyframe clouds on disk: each back bit for bit, the folder gone with the store; folders left by
// processes that ended without removing theirs (kill -9) go when the next store starts, those of
// a live process (and ones not named by a process) stay.
TEST(KeyframeSpill, RoundTripAndStaleFoldersOfDeadProcessesGo) {
  const auto dir = test::scratchDir();
  const char* before = std::getenv("TMPDIR");
  const std::string saved = before ? before : "";
  ::setenv("TMPDIR", dir.c_str(), 1);
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);  // its id is now a process that does not exist
  const fs::path stale = dir / ("hazmap-keyframes-" + std::to_string(child) + "-42");
  const fs::path alive = dir / ("hazmap-keyframes-" + std::to_string(::getppid()) + "-7");
  const fs::path foreign = dir / "hazmap-keyframes-123456";
  for (const auto& d : {stale, alive, foreign}) {
    fs::create_directories(d);
    std::ofstream(d / "0.pcd") << "x";
  }
  const LabeledCloud cloud = richCloud(300);
  {
    KeyframeSpill spill;
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_TRUE(fs::exists(alive));
    EXPECT_TRUE(fs::exists(foreign));
    spill.store(7, cloud);
    const LabeledCloud back = spill.load(7, ClassTable::defaults());
    EXPECT_EQ(back.points, cloud.points);
    EXPECT_EQ(back.classes, cloud.classes);
    EXPECT_EQ(back.intensity, cloud.intensity);
  }
  std::size_t ours = 0;
  for (const auto& e : fs::directory_iterator(dir))
    ours += e.path().filename().string().starts_with("hazmap-keyframes-" + std::to_string(::getpid()) + "-");
  EXPECT_EQ(ours, 0u);  // removed with the store
  if (before) ::setenv("TMPDIR", saved.c_str(), 1);
  else ::unsetenv("TMPDIR");
}

TEST(IoRoundTrip, PcdAllEncodingsKeepEveryChannel) {
  const auto dir = test::scratchDir();
  const LabeledCloud c = richCloud(2000);
  for (auto [enc, name] : {std::pair{PcdEncoding::Ascii, "a.pcd"}, {PcdEncoding::Binary, "b.pcd"},
                           {PcdEncoding::BinaryCompressed, "c.pcd"}}) {
    SCOPED_TRACE(name);
    writePcd(dir / name, c, enc);
    // The semantic-kitti table maps raw labels, but hazmap-written files hold class ids.
    ReadStats st;
    const auto back = readPcd(dir / name, ClassTable::semanticKitti(), &st);
    expectSameCloud(c, back);
    EXPECT_EQ(st.points_in_file, 2000u);
  }
  EXPECT_LT(fs::file_size(dir / "c.pcd"), fs::file_size(dir / "b.pcd"));
}

TEST(IoRoundTrip, RealScanThroughCompressedPcd) {
  const auto dir = test::scratchDir();
  const auto scan = readPcd(test::sharedData("scan-pair/251371071.pcd"));
  writePcd(dir / "s.pcd", scan, PcdEncoding::BinaryCompressed);
  expectSameCloud(scan, readPcd(dir / "s.pcd"));
}

TEST(IoRoundTrip, PlyAsciiAndBinaryWithColours) {
  const auto dir = test::scratchDir();
  const LabeledCloud c = richCloud(300);
  for (bool binary : {false, true}) {
    PlyWriteOptions opt;
    opt.binary = binary;
    for (std::size_t i = 0; i < c.size(); ++i) opt.colors.push_back({std::uint8_t(i), 2, 3});
    writePly(dir / "p.ply", c, opt);
    expectSameCloud(c, readPly(dir / "p.ply", ClassTable::semanticKitti()));
  }
  // writeCloud colours by class table.
  writeCloud(dir / "q.ply", c);
  expectSameCloud(c, readCloud(dir / "q.ply"));
  const std::string text = readTextFile(dir / "q.ply");
  EXPECT_NE(text.find("property uchar red"), std::string::npos);
}

TEST(IoRoundTrip, PlyMeshWithFaceClasses) {
  const auto dir = test::scratchDir();
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0.5f}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  m.triangle_classes = {1, 3};
  m.vertex_colors = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}, {9, 9, 9}};
  for (bool binary : {false, true}) {
    writePlyMesh(dir / "m.ply", m, binary);
    const auto back = readPlyMesh(dir / "m.ply");
    EXPECT_EQ(back.vertices, m.vertices);
    EXPECT_EQ(back.triangles, m.triangles);
    EXPECT_EQ(back.triangle_classes, m.triangle_classes);
    EXPECT_EQ(back.vertex_colors, m.vertex_colors);
  }
  // A mesh file is also a cloud (its vertices).
  EXPECT_EQ(readPly(dir / "m.ply").size(), 4u);
}

TEST(IoRoundTrip, PlyForeignFilesQuadsAndBigEndian) {
  const auto dir = test::scratchDir();
  // ASCII quad with an extra element before the vertices (skipped) → two triangles (a fan).
  writeTextAtomically(dir / "quad.ply",
                      "ply\nformat ascii 1.0\ncomment made by hand\nelement camera 1\nproperty float fov\n"
                      "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
                      "property uchar label\nelement face 1\nproperty list uchar uint vertex_index\n"
                      "end_header\n60\n0 0 0 7\n1 0 0 7\n1 1 0 80\n0 1 0 0\n4 0 1 2 3\n");
  const auto mesh = readPlyMesh(dir / "quad.ply");
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_EQ(mesh.triangles[1], Eigen::Vector3i(0, 2, 3));
  // Foreign labels go through the table's raw mapping (80 = pole → heat).
  const auto cloud = readPly(dir / "quad.ply", ClassTable::semanticKitti());
  ASSERT_EQ(cloud.size(), 4u);
  EXPECT_EQ(cloud.classes[2], 1);
  EXPECT_EQ(cloud.classes[0], 0);

  // Big-endian binary.
  std::string be = "ply\nformat binary_big_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                   "property float z\nproperty ushort intensity\nend_header\n";
  const auto putBe = [&](const void* p, std::size_t n) {
    const char* b = static_cast<const char*>(p);
    for (std::size_t k = 0; k < n; ++k) be.push_back(b[n - 1 - k]);
  };
  for (int i = 0; i < 2; ++i) {
    const float v[3] = {1.5f + i, -2.0f, 3.25f};
    for (float f : v) putBe(&f, 4);
    const std::uint16_t in = 1000 + i;
    putBe(&in, 2);
  }
  writeTextAtomically(dir / "be.ply", be);
  const auto b = readPly(dir / "be.ply");
  ASSERT_EQ(b.size(), 2u);
  EXPECT_EQ(b.points[1], Eigen::Vector3f(2.5f, -2.0f, 3.25f));
  EXPECT_EQ(b.intensity[1], 1001.0f);
}

TEST(IoRoundTrip, PcdForeignAsciiWithExtraFieldsAndNaN) {
  const auto dir = test::scratchDir();
  writeTextAtomically(dir / "f.pcd",
                      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb normal label t\nSIZE 4 4 4 4 4 2 8\n"
                      "TYPE F F F U F U F\nCOUNT 1 1 1 1 3 1 1\nWIDTH 4\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
                      "POINTS 4\nDATA ascii\n1 2 3 0 0 0 1 80 0.5\nnan 2 3 0 0 0 1 80 0.6\n"
                      "4 5 6 0 0 0 1 81 0.7\n7 8 inf 0 0 0 1 0 0.8\n");
  ReadStats st;
  const auto c = readPcd(dir / "f.pcd", ClassTable::semanticKitti(), &st);
  EXPECT_EQ(st.points_in_file, 4u);
  EXPECT_EQ(st.dropped_non_finite, 2u);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.points[1], Eigen::Vector3f(4, 5, 6));
  EXPECT_EQ(c.classes[0], 1);  // 80 → heat
  EXPECT_EQ(c.classes[1], 3);  // 81 → radiation
  ASSERT_TRUE(c.hasTimestamps());
  EXPECT_DOUBLE_EQ(c.timestamps[1], 0.7);
  EXPECT_FALSE(c.hasIntensity());
}

TEST(IoRoundTrip, KittiBinNaNPointsAreDroppedAndLabelsStayAligned) {
  const auto dir = test::scratchDir();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float pts[3][4] = {{1, 2, 3, 0.5f}, {nan, 0, 0, 0}, {4, 5, 6, 0.25f}};
  const std::uint32_t labels[3] = {80, 81, 71 | (5u << 16)};
  writeTextAtomically(dir / "n.bin", std::string(reinterpret_cast<const char*>(pts), sizeof pts));
  writeTextAtomically(dir / "n.label", std::string(reinterpret_cast<const char*>(labels), sizeof labels));
  ReadStats st;
  const auto c = readKittiScan(dir / "n.bin", dir / "n.label", ClassTable::semanticKitti(), &st);
  EXPECT_EQ(st.points_in_file, 3u);
  EXPECT_EQ(st.dropped_non_finite, 1u);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.classes[0], 1);
  EXPECT_EQ(c.classes[1], 2);  // instance bits ignored
  EXPECT_EQ(c.intensity[1], 0.25f);
}

TEST(IoRoundTrip, Trajectories) {
  const auto dir = test::scratchDir();
  Trajectory t;
  for (int i = 0; i < 20; ++i)
    t.push_back(1.3e9 + i * 0.1, fromXyzRpy(i * 0.7, -0.1 * i, 0.05, 0.01 * i, -0.02, 0.3 * i));
  writeKittiTrajectory(dir / "k.txt", t);
  writeTumTrajectory(dir / "t.txt", t);
  const auto k = readTrajectoryAuto(dir / "k.txt");
  const auto m = readTrajectoryAuto(dir / "t.txt");
  ASSERT_EQ(k.size(), 20u);
  ASSERT_EQ(m.size(), 20u);
  for (int i = 0; i < 20; ++i) {
    EXPECT_TRUE(k.poses[i].isApprox(t.poses[i], 1e-15));
    EXPECT_TRUE(m.poses[i].isApprox(t.poses[i], 1e-12));
    EXPECT_DOUBLE_EQ(m.stamps[i], t.stamps[i]);
    EXPECT_DOUBLE_EQ(k.stamps[i], i);
  }
  EXPECT_EQ(readTrajectory(dir / "t.txt", TrajectoryFormat::Tum).size(), 20u);
  EXPECT_THROW(readTrajectory(dir / "t.txt", TrajectoryFormat::Kitti), Error);
}

TEST(IoRoundTrip, SequenceWriterThenSequence) {
  const auto dir = test::scratchDir() / "seq";
  const auto scan = readKittiScan(test::sharedData(kKitti / "velodyne/000000.bin"),
                                  test::sharedData(kKitti / "labels/000000.label"), ClassTable::semanticKitti());
  Trajectory gt, odo;
  {
    SequenceWriter w(dir, ClassTable::semanticKitti(), "name: vlp16\nrings: 16\n");
    for (int i = 0; i < 3; ++i) {
      w.addFrame(scan.slice(std::size_t(i) * 1000, std::size_t(i) * 1000 + 5000));
      gt.push_back(i, fromXyYaw(i, 0, 0.1 * i));
      odo.push_back(i, fromXyYaw(i * 1.01, 0.02, 0.1 * i));
    }
    w.writeGroundTruth(gt);
    w.writeOdometry(odo);
    w.finish();
    EXPECT_EQ(w.frames(), 3u);
  }
  ASSERT_TRUE(fs::exists(dir / "velodyne/000002.bin"));
  ASSERT_TRUE(fs::exists(dir / "labels/000002.label"));
  const auto seq = Sequence::open(dir);
  ASSERT_EQ(seq.size(), 3u);
  ASSERT_TRUE(seq.groundTruth());
  ASSERT_TRUE(seq.odometry());
  EXPECT_TRUE(seq.odometry()->poses[2].isApprox(odo.poses[2], 1e-15));
  EXPECT_FALSE(seq.classTable().hasRawMapping());  // labels hold class ids
  EXPECT_EQ(seq.classTable().at(1).name, "heat");
  EXPECT_NE(seq.sensorYaml().find("rings: 16"), std::string::npos);
  const auto f1 = seq.frame(1);
  const auto expected = scan.slice(1000, 6000);
  EXPECT_EQ(f1.points, expected.points);
  EXPECT_EQ(f1.classes, expected.classes);
  EXPECT_GT(countClass(f1, 1) + countClass(f1, 2) + countClass(f1, 3), 0u);
}

TEST(IoRoundTrip, SequenceOfPcdFilesWithTableByName) {
  const auto dir = test::scratchDir();
  fs::create_directories(dir / "velodyne");
  writePcd(dir / "velodyne/000000.pcd", richCloud(10));
  writePly(dir / "velodyne/000001.ply", richCloud(12));
  writeTextAtomically(dir / "hazmap.yaml", "class_table: semantic-kitti\nsensor: {name: hdl64}\n");
  const auto seq = Sequence::open(dir);
  ASSERT_EQ(seq.size(), 2u);
  EXPECT_TRUE(seq.classTable().hasRawMapping());
  EXPECT_EQ(seq.frame(1).size(), 12u);
  EXPECT_EQ(seq.frame(0).classes, richCloud(10).classes);
  EXPECT_NE(seq.sensorYaml().find("hdl64"), std::string::npos);
}

TEST(IoKitti, SemanticKittiLabelsAreToldFromHazmapClasses) {
  EXPECT_FALSE(looksLikeSemanticKittiLabels({}));
  EXPECT_FALSE(looksLikeSemanticKittiLabels({0, 1, 2, 3}));  // hazmap's own classes
  EXPECT_TRUE(looksLikeSemanticKittiLabels({0, 40, 71, 80u | (7u << 16)}));  // instance ids ignored
  EXPECT_TRUE(looksLikeSemanticKittiLabels({1, 252}));
  EXPECT_FALSE(looksLikeSemanticKittiLabels({0, 71, 7}));  // 7 is no SemanticKITTI id
  EXPECT_FALSE(looksLikeSemanticKittiLabels({0, 71, 260}));
}

// Only a folder that names no table is recognised; hazmap.yaml's table is kept as it is.
TEST(IoKitti, OnlyAFolderWithoutATableIsRecognised) {
  const auto dir = test::scratchDir();
  LabeledCloud scan;
  for (int i = 0; i < 6; ++i) scan.push_back(Eigen::Vector3f(float(i), 1.0f, 0.0f), ClassId(i % 2 ? 71 : 40));
  fs::create_directories(dir / "velodyne");
  fs::create_directories(dir / "labels");
  writeKittiBin(dir / "velodyne/000000.bin", scan);
  writeSemanticKittiLabels(dir / "labels/000000.label", scan);
  const auto recognised = Sequence::open(dir);
  EXPECT_FALSE(recognised.tableNote().empty());
  EXPECT_EQ(countClass(recognised.frame(0), 2), 3u);  // trunk → water
  EXPECT_EQ(countClass(recognised.frame(0), 0), 3u);  // road → none
  writeTextAtomically(dir / "hazmap.yaml", "class_table: default\n");
  const auto named = Sequence::open(dir);
  EXPECT_TRUE(named.tableNote().empty());
  EXPECT_EQ(countClass(named.frame(0), 71), 3u);
  // Ids outside SemanticKITTI's set are not guessed at: the default table, as before.
  fs::remove(dir / "hazmap.yaml");
  scan.classes[0] = 7;
  writeSemanticKittiLabels(dir / "labels/000000.label", scan);
  EXPECT_TRUE(Sequence::open(dir).tableNote().empty());
}

TEST(IoLzf, CompressDecompressAndRejectCorruption) {
  std::mt19937 rng(3);
  for (std::size_t n : {0u, 1u, 2u, 3u, 31u, 33u, 1000u, 100000u}) {
    std::string data(n, '\0');
    for (std::size_t i = 0; i < n; ++i) data[i] = static_cast<char>((i % 97 < 50) ? 'a' + (i % 7) : rng() & 0xff);
    const std::string comp = io_detail::lzfCompress(data.data(), data.size());
    std::string back(n, '\0');
    ASSERT_EQ(io_detail::lzfDecompress(comp.data(), comp.size(), back.data(), n), n) << n;
    ASSERT_EQ(back, data) << n;
  }
  const std::string runs(10000, 'x');
  const std::string comp = io_detail::lzfCompress(runs.data(), runs.size());
  EXPECT_LT(comp.size(), 200u);
  std::string out(100, '\0');
  EXPECT_EQ(io_detail::lzfDecompress(comp.data(), comp.size(), out.data(), out.size()), 0u);  // too small
  const char bad_ref[] = {'\x20', '\x05'};  // back-reference before the start
  EXPECT_EQ(io_detail::lzfDecompress(bad_ref, 2, out.data(), out.size()), 0u);
  const char short_lit[] = {'\x05', 'a'};  // literal run longer than the input
  EXPECT_EQ(io_detail::lzfDecompress(short_lit, 2, out.data(), out.size()), 0u);
}
