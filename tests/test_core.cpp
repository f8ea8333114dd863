#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <limits>
#include <random>

#include "hazmap/core/journaled_list.hpp"
#include "hazmap/core/memory.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "test_helpers.hpp"

using namespace hazmap;

TEST(LabeledCloud, PushSelectSliceAppendKeepChannelsAligned) {
  LabeledCloud c;
  c.enableIntensity();
  for (int i = 0; i < 10; ++i) c.push_back({float(i), 0, 0}, ClassId(i % 3), float(i) * 2);
  ASSERT_EQ(c.size(), 10u);
  ASSERT_EQ(c.intensity.size(), 10u);
  EXPECT_FALSE(c.hasTimestamps());
  std::vector<std::size_t> idx{9, 1};
  auto s = c.select(idx);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s.points[0].x(), 9.0f);
  EXPECT_EQ(s.classes[1], 1);
  EXPECT_EQ(s.intensity[0], 18.0f);
  auto sl = c.slice(2, 5);
  EXPECT_EQ(sl.size(), 3u);
  EXPECT_EQ(sl.intensity[2], 8.0f);
  LabeledCloud no_i;
  no_i.push_back({1, 1, 1}, 2);
  auto joined = c;
  joined.append(no_i);
  EXPECT_EQ(joined.size(), 11u);
  EXPECT_FALSE(joined.hasIntensity());  // only channels both sides have survive
  joined.checkConsistent("joined");
  LabeledCloud empty;
  empty.append(c);
  EXPECT_TRUE(empty.hasIntensity());
}

TEST(LabeledCloud, RemoveNonFiniteCountsAndCompacts) {
  LabeledCloud c;
  c.enableProperty();
  c.push_back({1, 2, 3}, 1, 0, 0, 20.f);
  c.push_back({NAN, 2, 3}, 1);
  c.push_back({1, INFINITY, 3}, 1);
  c.push_back({4, 5, 6}, 2, 0, 0, NAN);
  c.push_back({7, 8, 9}, 3, 0, 0, 30.f);
  EXPECT_EQ(c.removeNonFinite(), 3u);
  ASSERT_EQ(c.size(), 2u);
  EXPECT_EQ(c.classes[1], 3);
  EXPECT_EQ(c.property[1], 30.f);
}

TEST(LabeledCloud, TransformAndBounds) {
  LabeledCloud c;
  c.push_back({1, 0, 0});
  c.push_back({0, 2, 0});
  const auto T = fromXyzRpy(1, 2, 3, 0, 0, M_PI / 2);
  auto t = c.transformed(T);
  EXPECT_NEAR(t.points[0].x(), 1.0f, 1e-6);
  EXPECT_NEAR(t.points[0].y(), 3.0f, 1e-6);
  EXPECT_NEAR(t.points[1].x(), -1.0f, 1e-6);
  const auto b = t.bounds();
  EXPECT_NEAR(b.min.x(), -1.0f, 1e-6);
  EXPECT_NEAR(b.max.y(), 3.0f, 1e-6);
}

TEST(LabeledCloud, InconsistentChannelIsReported) {
  LabeledCloud c;
  c.push_back({0, 0, 0});
  c.intensity = {1.f, 2.f};
  try {
    c.checkConsistent("scan.pcd");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("scan.pcd: intensity count 2"), std::string::npos);
  }
}

TEST(SE3, ExpLogRoundTripAndSmallAngles) {
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0, 1);
  for (int k = 0; k < 100; ++k) {
    Vector6d xi;
    for (int i = 0; i < 6; ++i) xi[i] = n(rng) * (k < 10 ? 1e-9 : 0.8);
    const auto T = se3Exp(xi);
    EXPECT_TRUE((se3Log(T) - xi).norm() < 1e-9) << xi.transpose();
    EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
  }
}

TEST(SE3, AdjointMatchesConjugation) {
  const auto T = fromXyzRpy(1, -2, 0.5, 0.1, -0.3, 1.2);
  Vector6d xi;
  xi << 0.1, 0.2, -0.1, 0.05, -0.02, 0.03;
  const Vector6d lhs = se3Log(T * se3Exp(xi) * T.inverse());
  EXPECT_LT((lhs - adjoint(T) * xi).norm(), 1e-9);
}

TEST(SE3, SwapOrderIsAnInvolution) {
  Matrix6d m = Matrix6d::Random();
  EXPECT_TRUE(swapTranslationRotation(swapTranslationRotation(m)).isApprox(m));
  Matrix6d d = Matrix6d::Zero();
  d(0, 0) = 1;  // x variance → becomes element (3,3) in rotation-first order
  EXPECT_EQ(swapTranslationRotation(d)(3, 3), 1.0);
  EXPECT_NEAR(yawOf(fromXyYaw(0, 0, 2.5)), 2.5, 1e-12);
  EXPECT_NEAR(rotationAngle(fromXyzRpy(0, 0, 0, 0.3, 0, 0)), 0.3, 1e-12);
  Eigen::Matrix3d noisy = so3Exp({0.1, 0.2, 0.3}) + 1e-3 * Eigen::Matrix3d::Random();
  const auto R = projectToSO3(noisy);
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  EXPECT_TRUE((R * R.transpose()).isIdentity(1e-12));
}

TEST(ClassTable, DefaultsAndSemanticKitti) {
  const auto t = ClassTable::defaults();
  EXPECT_EQ(t.size(), 4u);
  EXPECT_EQ(t.at(1).kind, PropertyKind::Heat);
  EXPECT_EQ(t.at(2).name, "water");
  EXPECT_FALSE(t.isProperty(0));
  EXPECT_TRUE(t.isProperty(3));
  EXPECT_EQ(t.mapRaw(2), 2);  // no raw map: identity
  const auto k = ClassTable::semanticKitti();
  EXPECT_EQ(k.mapRaw(80), 1);
  EXPECT_EQ(k.mapRaw(71), 2);
  EXPECT_EQ(k.mapRaw(81), 3);
  EXPECT_EQ(k.mapRaw(40), 0);
  EXPECT_THROW(t.at(9), Error);
}

TEST(ClassTable, YamlRoundTripAndShippedFiles) {
  const auto k = ClassTable::semanticKitti();
  const auto back = ClassTable::fromYamlString(k.toYamlString(), "mem");
  EXPECT_EQ(back.size(), k.size());
  EXPECT_EQ(back.mapRaw(81), 3);
  EXPECT_EQ(back.at(1).color, k.at(1).color);
  EXPECT_DOUBLE_EQ(back.at(2).search_radius, k.at(2).search_radius);
  for (const char* f : {"config/classes/default.yaml", "config/classes/semantic_kitti.yaml"}) {
    const auto t = ClassTable::fromYamlFile(test::sourceDir(f));
    EXPECT_EQ(t.size(), 4u) << f;
  }
  EXPECT_EQ(ClassTable::fromYamlFile(test::sourceDir("config/classes/semantic_kitti.yaml")).mapRaw(80), 1);
}

TEST(ClassTable, BadYamlGivesOneLineErrorNamingTheFile) {
  const auto expectError = [](const std::string& yaml, const std::string& needle) {
    try {
      ClassTable::fromYamlString(yaml, "t.yaml");
      ADD_FAILURE() << "no error for: " << yaml;
    } catch (const Error& e) {
      const std::string msg = e.what();
      EXPECT_EQ(msg.rfind("t.yaml: ", 0), 0u) << msg;
      EXPECT_NE(msg.find(needle), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  };
  expectError("classes: [", "invalid YAML");
  expectError("foo: 1", "'classes'");
  expectError("classes:\n  - {id: 0, name: a, kind: lava}", "unknown kind 'lava'");
  expectError("classes:\n  - {id: 70000, name: a}", "out of range");
  expectError("classes:\n  - {id: 1, name: a, search_radius: -1}", "search_radius");
  expectError("classes:\n  - {id: 1, name: a, search_radius: abc}", "search_radius");
  expectError("classes:\n  - {id: 1, name: a}\n  - {id: 1, name: b}", "defined twice");
  expectError("classes:\n  - {id: 0, name: a}\nraw_labels: {80: 5}", "unknown class 5");
  expectError("mismatch_penalty: -2\nclasses:\n  - {id: 0, name: a}", "mismatch_penalty");
  EXPECT_THROW(ClassTable::fromYamlFile("/nonexistent/t.yaml"), Error);
}

TEST(ClassTable, CheckCloudRejectsUnknownClass) {
  LabeledCloud c;
  c.push_back({0, 0, 0}, 0);
  c.push_back({0, 0, 0}, 7);
  EXPECT_THROW(ClassTable::defaults().checkCloud(c, "x.bin"), Error);
}

#include "hazmap/preprocess/voxel_downsample.hpp"

TEST(VoxelDownsample, CentroidAndVotes) {
  LabeledCloud c;
  c.enableIntensity();
  // voxel A (0..1): three "none" points and one heat point
  c.push_back({0.1f, 0.1f, 0.1f}, 0, 1.f);
  c.push_back({0.3f, 0.1f, 0.1f}, 0, 1.f);
  c.push_back({0.5f, 0.1f, 0.1f}, 0, 1.f);
  c.push_back({0.7f, 0.1f, 0.1f}, 1, 5.f);
  // voxel B: one water point
  c.push_back({2.5f, 0.5f, 0.5f}, 2, 3.f);
  VoxelDownsampleConfig cfg;
  cfg.voxel_size = 1.0;
  auto m = voxelDownsample(c, cfg);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_NEAR(m.points[0].x(), 0.4f, 1e-6);
  EXPECT_EQ(m.classes[0], 0);
  EXPECT_NEAR(m.intensity[0], 2.0f, 1e-6);
  EXPECT_EQ(m.classes[1], 2);
  cfg.vote = ClassVote::PreferProperty;
  cfg.property_share = 0.25;
  auto p = voxelDownsample(c, cfg);
  EXPECT_EQ(p.classes[0], 1);  // 1 of 4 points is heat: enough under PreferProperty
  cfg.voxel_size = 0;
  EXPECT_THROW(voxelDownsample(c, cfg), Error);
  cfg.voxel_size = -1;
  EXPECT_THROW(voxelDownsample(c, cfg), Error);
  cfg.voxel_size = 1;
  EXPECT_TRUE(voxelDownsample(LabeledCloud{}, cfg).empty());
}

#if defined(__GLIBC__)
// The CLI and the benchmarks call it at start-up; on glibc both malloc settings must be taken
// (a refused one would silently bring back the page-fault cost measured in docs/registration.md).
TEST(Memory, RetainFreedMemoryIsAcceptedByGlibc) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer replaces glibc's malloc, so mallopt does not apply (make asan)";
#endif
  EXPECT_TRUE(hazmap::retainFreedMemory());
  std::vector<char> big(8 << 20, 1);  // served from the heap now, and still usable
  EXPECT_EQ(big[(8 << 20) - 1], 1);
}

std::size_t residentBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

// Retained memory goes back to the system on request (a long live mission, issue 33): 64 MiB
// freed in the middle of the heap (a block after it still in use) stay resident until
// releaseFreedMemory(), then at least 48 MiB of them are returned.
TEST(Memory, ReleaseFreedMemoryReturnsWhatIsFreed) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer replaces glibc's malloc (make asan)";
#endif
  ASSERT_TRUE(hazmap::retainFreedMemory());
  std::vector<std::unique_ptr<char[]>> blocks;
  for (int i = 0; i < 64; ++i) {
    blocks.emplace_back(new char[1 << 20]);
    std::memset(blocks.back().get(), 1, 1 << 20);  // resident
  }
  auto after = std::make_unique<char[]>(4096);  // keeps the heap's top in use
  after[0] = 1;
  blocks.clear();
  const std::size_t held = residentBytes();
  EXPECT_TRUE(hazmap::releaseFreedMemory());
  const std::size_t released = held > residentBytes() ? held - residentBytes() : 0;
  EXPECT_GE(released, std::size_t{48} << 20) << "held " << (held >> 20) << " MiB";
  EXPECT_EQ(after[0], 1);
}
#endif

// A journaled list (issue 33) gives back every entry exactly as it was pushed, wherever it is
// (memory or journal), by index, by cursor across block boundaries and whole; the newest stay in
// memory and writable, an older one is not, and pushing on after journaling keeps the order.
TEST(JournaledList, EntriesComeBackBitForBitFromMemoryAndJournal) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 10.0);
  std::vector<Eigen::Isometry3d> pushed;
  JournaledList<Eigen::Isometry3d> list("test journal");
  auto pushRandom = [&](int n) {
    for (int i = 0; i < n; ++i) {
      Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
      T.linear() = Eigen::AngleAxisd(g(rng), Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized()).toRotationMatrix();
      T.translation() = Eigen::Vector3d(g(rng), g(rng), g(rng));
      if (i == 7) T.translation().x() = std::nextafter(1.0, 2.0);  // the last bit matters
      pushed.push_back(T);
      list.push_back(T);
    }
  };
  pushRandom(5000);
  EXPECT_EQ(list.firstInMemory(), 0u);  // a plain list until told
  list.keepNewest(24);
  pushRandom(4500);  // the journal now spans more than one of the cursor's blocks (4096)
  ASSERT_EQ(list.size(), pushed.size());
  EXPECT_EQ(list.firstInMemory(), pushed.size() - 24);
  auto same = [](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
    return std::memcmp(a.matrix().data(), b.matrix().data(), sizeof(double) * 16) == 0;
  };
  for (std::size_t k : {std::size_t{0}, std::size_t{7}, std::size_t{4095}, std::size_t{4096}, pushed.size() - 25,
                        pushed.size() - 24, pushed.size() - 1})
    EXPECT_TRUE(same(list.at(k), pushed[k])) << k;
  const std::vector<Eigen::Isometry3d> all = list.all();
  ASSERT_EQ(all.size(), pushed.size());
  for (std::size_t k = 0; k < all.size(); ++k) ASSERT_TRUE(same(all[k], pushed[k])) << k;
  JournaledList<Eigen::Isometry3d>::Cursor from_middle(list);
  for (std::size_t k = 3000; k < pushed.size(); k += 3) ASSERT_TRUE(same(from_middle(k), pushed[k])) << k;
  EXPECT_THROW(list[pushed.size() - 25], std::out_of_range);
  list[pushed.size() - 1].translation().z() = 42.0;  // the newest are writable (re-estimated frames)
  EXPECT_EQ(list.at(pushed.size() - 1).translation().z(), 42.0);
  EXPECT_EQ(list.back().translation().z(), 42.0);
}

TEST(JournaledList, AMissingTemporaryFolderIsAOneLineErrorAndTheListStaysWhole) {
  const char* before = std::getenv("TMPDIR");
  const std::string saved = before ? before : "";
  ::setenv("TMPDIR", "/nonexistent/hazmap-test", 1);
  JournaledList<Matrix6d> list("step covariance journal");
  list.push_back(Matrix6d::Identity());
  try {
    list.keepNewest(1);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("hazmap-test"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
  if (before) ::setenv("TMPDIR", saved.c_str(), 1);
  else ::unsetenv("TMPDIR");
  list.push_back(2.0 * Matrix6d::Identity());
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list.firstInMemory(), 0u);
  EXPECT_EQ(list.at(1)(0, 0), 2.0);
}

// voxelOfPoint (the per-point path of the downsampling and the local map) must give exactly what
// voxelCoordinate on each axis then voxelKey give: same coordinates, same key, same refusals.
TEST(VoxelKey, PointPathAgreesWithCoordinateThenKey) {
  const double B = double(kVoxelKeyBias);
  std::vector<double> values = {0.0, -0.0, 0.5, -0.5, 1.0, -1.0, -1e-300, 1e-300, 3.999999999, -3.000000001,
                                B - 1.0, B - 1e-9, B, B + 0.5, -B, -B + 0.5, -B - 1e-9, -B - 1.0, 1e300, -1e300,
                                std::nan(""), INFINITY, -INFINITY, std::nextafter(B, 0.0), std::nextafter(-B, -2 * B)};
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> wide(-1.5 * B, 1.5 * B), narrow(-50.0, 50.0);
  for (int i = 0; i < 2000; ++i) values.push_back(i % 2 ? wide(rng) : narrow(rng));
  std::size_t accepted = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double x = values[i], y = values[(i * 7 + 3) % values.size()], z = values[(i * 13 + 5) % values.size()];
    std::int64_t cx = 0, cy = 0, cz = 0;
    std::uint64_t expected = 0;
    const bool ok = voxelCoordinate(x, cx) && voxelCoordinate(y, cy) && voxelCoordinate(z, cz) &&
                    voxelKey(cx, cy, cz, expected);
    std::array<std::int64_t, 3> c{};
    std::uint64_t key = 0;
    ASSERT_EQ(voxelOfPoint(x, y, z, c, key), ok) << x << " " << y << " " << z;
    if (!ok) continue;
    ++accepted;
    EXPECT_EQ(c, (std::array<std::int64_t, 3>{cx, cy, cz}));
    EXPECT_EQ(key, expected);
    EXPECT_EQ(unpackVoxelKey(key), c);
  }
  EXPECT_GT(accepted, 500u);
  std::uint64_t key = 0;
  EXPECT_FALSE(voxelKey(-kVoxelKeyBias - 1, 0, 0, key));
  EXPECT_FALSE(voxelKey(0, kVoxelKeyBias, 0, key));
  EXPECT_TRUE(voxelKey(-kVoxelKeyBias, kVoxelKeyBias - 1, 0, key));
  EXPECT_FALSE(voxelKey(0, 0, std::numeric_limits<std::int64_t>::min() / 2, key));
}
