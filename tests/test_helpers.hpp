#pragma once
// Shared test helpers: paths to the shared real data and a fresh scratch folder per test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <unistd.h>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/se3.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/sim/simulator.hpp"
#include "test_paths.hpp"

namespace hazmap::test {

/// Scan i of the SemanticKITTI sample (../shared/data/kitti-semantic-sample), labels mapped by
/// `table`.
inline LabeledCloud kittiScan(int i, const ClassTable& table) {
  char name[32];
  std::snprintf(name, sizeof name, "%06d", i);
  const auto dir = sharedData("kitti-semantic-sample");
  return readKittiScan(dir / "velodyne" / (std::string(name) + ".bin"),
                       dir / "labels" / (std::string(name) + ".label"), table);
}

/// How far pose `b` is from pose `a`: the translation (m) and rotation angle (degrees) of a⁻¹·b.
inline double transErr(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.inverse() * b).translation().norm();
}
inline double rotErrDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return rotationAngle(a.inverse() * b) * 180.0 / M_PI;
}

inline std::filesystem::path sourceDir(const std::string& rel = "") { return sourceRoot() / rel; }

/// A new empty folder named after the running test.
inline std::filesystem::path scratchDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const char* base = std::getenv("HAZMAP_TEST_TMP");
  std::filesystem::path dir = std::filesystem::path(base ? base : "/tmp/hazmap-test") /
                              (std::string(info->test_suite_name()) + "." + info->name());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// A new folder with a short path under /tmp, removed with this object: Chromium's TMPDIR. A
/// killed Chromium leaves its singleton socket folder (org.chromium.Chromium.*) in TMPDIR, and
/// a Unix socket path must stay under 108 bytes, which a scratchDir() path may not.
class ShortTempDir {
 public:
  ShortTempDir() {
    char name[] = "/tmp/hzchrome.XXXXXX";
    if (::mkdtemp(name)) path_ = name;
  }
  ~ShortTempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  ShortTempDir(const ShortTempDir&) = delete;
  ShortTempDir& operator=(const ShortTempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// The message of the hazmap::Error that f throws; "" when it throws none.
inline std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

struct CommandResult {
  int exit_code = 0;
  std::string output;  ///< stdout and stderr together
};

/// Runs the hazmap CLI with the given argument string (shell-quoted by the caller).
inline CommandResult runCli(const std::string& args) {
  const std::string cmd = cliPath() + " " + args + " 2>&1";
  CommandResult r;
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return {-1, "popen failed"};
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return r;
}

/// Writes a short simulated sequence under HAZMAP_TEST_TMP and returns its folder. The name
/// carries the process id: CTest runs each test as its own process, so each writes its own copy
/// (callers keep the path in a function-local static to write it once per process).
inline std::filesystem::path writeSimulatedSequence(const std::string& tag, const std::string& scenario,
                                                    std::uint64_t seed, std::size_t frames) {
  const char* base = std::getenv("HAZMAP_TEST_TMP");
  const std::filesystem::path d = std::filesystem::path(base ? base : "/tmp/hazmap-test") /
                                  (tag + "-seq-" + std::to_string(::getpid()));
  sim::SimulatorConfig c;
  c.scenario = scenario;
  c.seed = seed;
  c.max_frames = frames;
  std::filesystem::create_directories(d.parent_path());
  sim::writeSimulation(c, d, /*overwrite=*/true);
  return d;
}

/// `laps` laps of a 20 m × 10 m rectangle driven counter-clockwise from the origin in steps of
/// `step` m (dividing 1 m), rising `climb` m a step: the true poses of the pose-graph tests' routes.
inline std::vector<Eigen::Isometry3d> rectangleLaps(int laps, double step, double climb) {
  const int lap = static_cast<int>(std::lround(60.0 / step));
  std::vector<Eigen::Isometry3d> poses;
  for (int i = 0; i < laps * lap; ++i) {
    const double s = step * (i % lap);
    double x, y, yaw;
    if (s < 20) x = s, y = 0, yaw = 0;
    else if (s < 30) x = 20, y = s - 20, yaw = M_PI / 2;
    else if (s < 50) x = 20 - (s - 30), y = 10, yaw = M_PI;
    else x = 0, y = 10 - (s - 50), yaw = -M_PI / 2;
    poses.push_back(fromXyzRpy(x, y, climb * i, 0, 0, yaw));
  }
  return poses;
}

}  // namespace hazmap::test
