// Properties stage speed: projecting a 120k-point scan (SemanticKITTI scan 0, a dense HDL-64
// sweep) into a 640×512 thermal image with the depth test, on one core (target ≤ 3 ms), beside
// the same projection without the depth test (splat 0, one-pixel cells) to show what the test
// costs, and the whole labeler step (image nearest in time, projection, rules). View fusion's
// best-view search (hazmap label's second pass) with three cameras over ten scans 0.3 m apart.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "bench_main.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/properties/labeler.hpp"
#include "hazmap/properties/projection.hpp"
#include "hazmap/properties/view_fusion.hpp"

using namespace hazmap;

namespace {

/// A 120k-point scan: the KITTI sample's scan 0 when the shared data is there, else a synthetic
/// room of the same size.
const LabeledCloud& scan120k() {
  static const LabeledCloud cloud = [] {
    const std::filesystem::path bin =
        std::filesystem::path(HAZMAP_SHARED_DATA_DIR) / "kitti-semantic-sample/velodyne/000000.bin";
    if (std::filesystem::exists(bin)) return readKittiBin(bin);
    LabeledCloud c;
    for (int i = 0; i < 120000; ++i) {
      const double az = 2 * M_PI * (i % 2000) / 2000.0, el = -0.4 + 0.5 * (i / 2000) / 60.0;
      const double r = 5 + 3 * std::sin(3 * az);
      c.push_back(Eigen::Vector3f(r * std::cos(el) * std::cos(az), r * std::cos(el) * std::sin(az), r * std::sin(el)));
    }
    return c;
  }();
  return cloud;
}

CameraCalibration thermal640() {
  CameraIntrinsics k;
  k.width = 640;
  k.height = 512;
  k.fx = k.fy = 320.0 / std::tan(25.0 * M_PI / 180.0);  // 50° HFOV
  k.cx = 319.5;
  k.cy = 255.5;
  k.distortion = DistortionModel::RadialTangential;
  k.coeffs = {-0.05, 0.01, 0, 0, 0};
  CameraCalibration cam;
  cam.model = CameraModel(k);
  cam.T_camera_lidar.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // looking along LiDAR x
  cam.channel = defaultChannel("temperature");
  return cam;
}

PropertyImage image640() {
  PropertyImage img;
  img.width = 640;
  img.height = 512;
  img.values.resize(640 * 512);
  for (std::size_t i = 0; i < img.values.size(); ++i) img.values[i] = 20.0f + static_cast<float>(i % 97) * 0.5f;
  return img;
}

void project(benchmark::State& state, const ProjectionConfig& config) {
  const LabeledCloud& scan = scan120k();
  const CameraCalibration cam = thermal640();
  const PropertyImage img = image640();
  std::vector<float> values(scan.size());
  ProjectionScratch scratch;
  ProjectionStats stats;
  for (auto _ : state) {
    std::fill(values.begin(), values.end(), NAN);
    stats = projectIntoImage(scan.points, cam.T_camera_lidar, cam.model, img, config, values, {}, &scratch);
    benchmark::DoNotOptimize(values.data());
  }
  state.counters["points"] = static_cast<double>(scan.size());
  state.counters["in_view"] = static_cast<double>(stats.in_view);
  state.counters["occluded"] = static_cast<double>(stats.occluded);
}

/// ViewFusion::bestFrames for the middle of ten 120k-point scans 0.3 m apart, three forward
/// cameras (temperature, NIR, dose rate), each scan's own images.
void bestFrames(benchmark::State& state) {
  const LabeledCloud& scan = scan120k();
  std::vector<CameraInput> cameras;
  for (const char* channel : {"temperature", "nir_reflectance", "dose_rate"}) {
    CameraCalibration cam = thermal640();
    cam.channel = defaultChannel(channel);
    auto images = std::make_shared<MemoryImages>();
    for (int k = 0; k < 10; ++k) {
      PropertyImage img = image640();
      img.stamp = k;
      images->add(img);
    }
    cameras.push_back({cam, images});
  }
  LabelerConfig config;
  config.footprints = true;
  const PropertyLabeler labeler(cameras, PropertyRules::defaults({"temperature"}, ClassTable::defaults()), config);
  ViewFusion fusion(labeler, ViewFusionConfig{});
  for (int k = 0; k < 10; ++k)
    fusion.add(k, scan, Eigen::Isometry3d(Eigen::Translation3d(0.3 * k, 0, 0)), 0.3 * k, labeler.observe(scan, k));
  std::size_t fused = 0;
  for (auto _ : state) {
    const std::vector<std::int32_t> best = fusion.bestFrames(5, scan);
    fused = static_cast<std::size_t>(std::count_if(best.begin(), best.end(), [](std::int32_t f) { return f >= 0; }));
    benchmark::DoNotOptimize(best.data());
  }
  state.counters["views"] = static_cast<double>(fusion.observations());
  state.counters["fused"] = static_cast<double>(fused);
}

}  // namespace

static void BM_Project120kDepthTest(benchmark::State& state) { project(state, ProjectionConfig{}); }
BENCHMARK(BM_Project120kDepthTest)->Unit(benchmark::kMillisecond);

static void BM_Project120kNoDepthTest(benchmark::State& state) {
  ProjectionConfig c;
  c.depth_cell_px = 1;
  c.splat_cells = 0;
  c.depth_tolerance = 1e9;
  project(state, c);
}
BENCHMARK(BM_Project120kNoDepthTest)->Unit(benchmark::kMillisecond);

static void BM_Label120kOneCamera(benchmark::State& state) {
  const LabeledCloud& scan = scan120k();
  auto images = std::make_shared<MemoryImages>();
  images->add(image640());
  const PropertyLabeler labeler({{thermal640(), images}}, PropertyRules::defaults({"temperature"}, ClassTable::defaults()));
  for (auto _ : state) {
    const ScanLabels l = labeler.label(scan, 0.0);
    benchmark::DoNotOptimize(l.classes.data());
  }
}
BENCHMARK(BM_Label120kOneCamera)->Unit(benchmark::kMillisecond);

static void BM_FusionBestFrames3Cameras(benchmark::State& state) { bestFrames(state); }
BENCHMARK(BM_FusionBestFrames3Cameras)->Unit(benchmark::kMillisecond);

HAZMAP_BENCHMARK_MAIN();
