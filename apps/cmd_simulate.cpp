// hazmap simulate: writes a simulated sequence of the paper's experiment (see docs/simulator.md).
#include <fmt/format.h>

#include <iostream>
#include <memory>
#include <random>
#include <sstream>

#include "command.hpp"
#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/imu.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/sequence.hpp"
#include "hazmap/map/render.hpp"
#include "hazmap/preprocess/voxel_downsample.hpp"
#include "hazmap/sim/missions.hpp"
#include "hazmap/sim/simulator.hpp"
#include "hazmap/sim/velodyne_packets.hpp"
#include "hazmap/sources/pcap_writer.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/properties/camera.hpp"
#include "hazmap/properties/property_image.hpp"
#include "hazmap/sources/mcap_export.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap::cli {
namespace {

/// Top-down PNGs of the written sequence: the reference map (true poses, as the paper's Fig. 6)
/// and the map built from odometry.txt alone, in one shared view. Points above `clip` (m) are
/// left out so the corridor's ceiling does not hide its floor.
void renderPngs(const std::filesystem::path& dir, double voxel, double clip) {
  const Sequence seq = Sequence::open(dir);
  if (!seq.odometry()) fail(dir.string(), "--png needs the sequence's odometry.txt (not written with wheel_odometry: false)");
  const ClassTable& table = seq.classTable();
  const LabeledCloud reference = readPly(dir / "reference_map.ply", table);
  LabeledCloud odometry_points;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    LabeledCloud scan = seq.frame(i);
    scan.transform(seq.odometry()->poses[i]);
    LabeledCloud plain;
    plain.points = std::move(scan.points);
    plain.classes = std::move(scan.classes);
    odometry_points.append(plain);
  }
  VoxelDownsampleConfig vc;
  vc.voxel_size = voxel;
  const LabeledCloud odometry_map = voxelDownsample(odometry_points, vc, table);
  const auto truth_xyz = positionsOf(*seq.groundTruth());
  const auto odo_xyz = positionsOf(*seq.odometry());
  TopDownConfig config;
  config.clip_above = clip;
  config.cell_size = voxel;
  config.draw_hazard_labels = false;
  config.pixels_per_metre = 25.0;
  config.view = unite(viewOf(reference, truth_xyz), viewOf(odometry_map, odo_xyz));
  config.title = "Reference map (true poses)";
  writePng(dir / "reference_map.png", renderTopDown(reference, table, truth_xyz, {}, config));
  config.title = "Map from odometry.txt";
  writePng(dir / "odometry_map.png", renderTopDown(odometry_map, table, odo_xyz, {}, config));
}

struct SimulateOptions {
  std::string scenario = "naraha";
  std::string out;
  std::uint64_t seed = 1;
  std::size_t frames = 0;
  std::string config;
  std::string scene;
  std::string regions;
  bool overwrite = false;
  bool temperature = false;
  bool png = false;
  std::string format = "folder";
  std::string cameras;
  std::string calibration_error;
  double time_offset = 0.0;
  bool camera_blur = false;
  std::string camera_size;
  std::string camera_rig;
  std::string image_format = "mono16";
  bool worst_day = false;
  bool no_odometry = false;
  double imu_rate = 0.0;
  int mission = 0;  ///< 0: not a mission (the scene as built in)
  bool closed_route = false;
};

/// --mission K: the scene as mission K finds it, its part of the route, changes_truth.json.
sim::SimulationSummary writeMissionFolder(const SimulateOptions& o, const sim::SimulatorConfig& config) {
  if (o.format != "folder") fail("--mission", "writes a sequence folder, not --format " + o.format);
  const ClassTable table = ClassTable::load(config.class_table);
  const sim::MissionPlan plan = sim::planMission(sim::loadConfiguredScene(config, table), o.mission, config.seed, config);
  const auto summary = sim::writeMission(config, plan, o.out, o.overwrite);
  std::cout << fmt::format("mission {} of {}: {} scene change(s) against mission 1 (changes_truth.json); poses.txt in "
                           "mission 1's frame\n", o.mission, plan.scene.name, plan.changes.size());
  return summary;
}

/// --format mcap: the sequence is simulated into a temporary folder next to the bag, then written
/// as a ROS 2 MCAP bag (sources/mcap_export.hpp) and the folder removed.
/// Each simulated camera's images on /<name>/image_raw, stamped with its times.txt: as
/// sensor_msgs/Image (mono16, its 16-bit PNGs' raw counts) or, with `png`, as
/// sensor_msgs/CompressedImage holding the 16-bit PNG itself; `yamls` receives each
/// camera.yaml's text pointing at that topic instead of the folder.
std::vector<McapExtraTopic> cameraTopics(const std::filesystem::path& folder, const sim::CameraSimConfig& cameras,
                                         bool png, std::vector<std::pair<std::string, std::string>>& yamls) {
  std::vector<McapExtraTopic> topics;
  for (const auto& c : cameras.placedCameras()) {
    const std::filesystem::path dir = folder / "cameras" / c.name;
    CameraCalibration cal = readCameraYaml(dir / "camera.yaml");
    cal.topic = "/" + c.name + "/image_raw";
    yamls.emplace_back(c.name, cameraYaml(cal, ""));
    const ImageFolder images(dir);
    McapExtraTopic t{cal.topic, png ? "sensor_msgs/msg/CompressedImage" : "sensor_msgs/msg/Image", images.stamps(), {}};
    t.message = [dir, png, stamps = images.stamps(), name = c.name](std::size_t i) {
      char file[32];
      std::snprintf(file, sizeof file, "%06zu.png", i);
      if (png) {
        const std::string bytes = readTextFile(dir / file);
        return encodeCompressedImage({{stamps[i], name}, "mono16; png compressed", {bytes.begin(), bytes.end()}});
      }
      const Gray16 raw = readGray16(dir / file);
      ImageMsg msg;
      msg.header = {stamps[i], name};
      msg.width = static_cast<std::uint32_t>(raw.width);
      msg.height = static_cast<std::uint32_t>(raw.height);
      msg.encoding = "mono16";
      msg.step = msg.width * 2;
      msg.data.resize(raw.pixels.size() * 2);
      for (std::size_t k = 0; k < raw.pixels.size(); ++k) {  // little endian
        msg.data[2 * k] = static_cast<std::uint8_t>(raw.pixels[k] & 0xFF);
        msg.data[2 * k + 1] = static_cast<std::uint8_t>(raw.pixels[k] >> 8);
      }
      return encodeImage(msg);
    };
    topics.push_back(std::move(t));
  }
  return topics;
}

/// --format pcap --cameras: the cameras' folders (images, times.txt, camera.yaml) beside the
/// capture as CAPTURE_STEM.cameras/<name>/, for `hazmap run CAPTURE --camera` and `hazmap replay
/// --camera` (the packets carry no image).
void keepPcapCameras(const std::filesystem::path& cameras, const std::filesystem::path& capture, bool overwrite) {
  namespace fs = std::filesystem;
  const fs::path target = capture.parent_path() / (capture.stem().string() + ".cameras");
  std::error_code ec;
  if (fs::exists(target, ec) && !overwrite) fail(target.string(), "exists (pass --overwrite to replace it)");
  fs::remove_all(target);
  fs::create_directories(target.parent_path());
  fs::rename(cameras, target);  // the same folder (the simulated sequence sits beside the capture)
  for (const auto& entry : fs::directory_iterator(target))
    if (fs::exists(entry.path() / "camera.yaml"))
      std::cout << fmt::format("  camera {}\n", (entry.path() / "camera.yaml").string());
}

/// --format pcap: the sequence simulated into a temporary folder, each scan written as the VLP-16's
/// data packets to port 2368 (sim/velodyne_packets.hpp) into a capture renamed into place at the
/// end. Packets carry no class, odometry or truth: a run on the capture is geometry alone.
void writeSimulationAsPcap(const sim::SimulatorConfig& config, const std::filesystem::path& capture, bool overwrite) {
  namespace fs = std::filesystem;
  sim::checkVlp16Layout(config.sensor, "--format pcap");
  std::error_code ec;
  if (fs::exists(capture, ec) && !overwrite) fail(capture.string(), "exists (pass --overwrite to replace it)");
  if (fs::is_directory(capture, ec)) fail(capture.string(), "is a folder; --format pcap writes one .pcap file");
  const fs::path absolute = fs::absolute(capture);
  const std::string tag = std::to_string(std::random_device{}() % 1000000);
  const fs::path folder = absolute.parent_path() / ("." + absolute.filename().string() + ".sequence-" + tag);
  const fs::path partial = absolute.parent_path() / ("." + absolute.filename().string() + ".tmp-" + tag);
  struct Remove {
    fs::path a, b;
    ~Remove() {
      std::error_code ignored;
      fs::remove_all(a, ignored);
      fs::remove(b, ignored);
    }
  } cleanup{folder, partial};
  const auto summary = sim::writeSimulation(config, folder, /*overwrite=*/false);
  const auto scans = sequenceScanSource(Sequence::open(folder));
  std::size_t frames = 0, packets = 0;
  {
    PcapWriter writer(partial);
    while (const auto scan = scans->next()) {
      for (const auto& p : sim::vlp16Packets(scan->cloud, config.sensor, scan->stamp)) writer.write(p.time_ns, 2368, p.bytes, 2368);
      ++frames;
    }
    packets = writer.datagrams();
    writer.flush();
  }
  fs::rename(partial, absolute);
  std::cout << fmt::format("wrote {}: {} frames as {} VLP-16 data packets (port 2368), {:.1f} m route\n",
                           capture.string(), frames, packets, summary.route_length);
  if (fs::is_directory(folder / "cameras", ec)) keepPcapCameras(folder / "cameras", absolute, overwrite);
}

/// The simulated imu.txt as sensor_msgs/Imu on /imu (sensor frame: frame_id velodyne).
McapExtraTopic imuTopic(const std::filesystem::path& imu_txt) {
  auto samples = std::make_shared<std::vector<ImuSample>>(readImuFile(imu_txt));
  McapExtraTopic t{"/imu", "sensor_msgs/msg/Imu", {}, {}};
  for (const auto& s : *samples) t.stamps.push_back(s.time);
  t.message = [samples](std::size_t i) {
    const ImuSample& s = (*samples)[i];
    return encodeImu({{s.time, "velodyne"}, s.gyro, s.accel});
  };
  return t;
}

void writeSimulationAsMcap(const sim::SimulatorConfig& config, const std::filesystem::path& bag, bool overwrite,
                           bool png_images) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(bag, ec) && !overwrite) fail(bag.string(), "exists (pass --overwrite to replace it)");
  if (fs::is_directory(bag, ec)) fail(bag.string(), "is a folder; --format mcap writes one .mcap file");
  const fs::path absolute = fs::absolute(bag);
  const fs::path folder =
      absolute.parent_path() / ("." + absolute.filename().string() + ".sequence-" + std::to_string(std::random_device{}() % 1000000));
  struct RemoveFolder {
    fs::path path;
    ~RemoveFolder() {
      std::error_code ignored;
      fs::remove_all(path, ignored);
    }
  } cleanup{folder};
  const auto summary = sim::writeSimulation(config, folder, /*overwrite=*/false);
  const auto scans = sequenceScanSource(Sequence::open(folder));
  std::vector<std::pair<std::string, std::string>> yamls;
  auto extra = cameraTopics(folder, config.cameras, png_images, yamls);
  if (fs::exists(folder / "imu.txt", ec)) extra.push_back(imuTopic(folder / "imu.txt"));
  const McapExportSummary written = writeScansAsMcap(*scans, bag, extra);
  std::cout << fmt::format("wrote {}: {} frames ({} PointCloud2 on /velodyne_points, {} Odometry on /odom, {} "
                           "PoseStamped on /ground_truth), {:.1f} m route\n",
                           bag.string(), written.scans, written.scans, written.odometry, written.ground_truth,
                           summary.route_length);
  // The cameras' calibrations beside the bag: BAG_STEM.<camera>.yaml (topic: instead of images:).
  for (std::size_t k = 0; k < yamls.size(); ++k) {
    const fs::path yaml = absolute.parent_path() / (absolute.stem().string() + "." + yamls[k].first + ".yaml");
    writeTextAtomically(yaml, yamls[k].second);
    std::cout << fmt::format("  {} images on {}; calibration {}\n", extra[k].stamps.size(), extra[k].topic, yaml.string());
  }
  if (config.cameras.rig.empty()) return;
  std::string rig = "# the simulated camera rig: hazmap label BAG --camera BAG_STEM.rig.yaml\ncameras:\n";
  for (const auto& [name, text] : yamls) rig += "  - " + absolute.stem().string() + "." + name + ".yaml\n";
  const fs::path rig_yaml = absolute.parent_path() / (absolute.stem().string() + ".rig.yaml");
  writeTextAtomically(rig_yaml, rig);
  std::cout << fmt::format("  camera rig {}\n", rig_yaml.string());
}


/// --camera-rig: a preset name (ring4, front-rear) or a YAML file with `rig: [{name, yaw_deg,
/// hfov_deg}, …]` (or the list at top level), read by the simulator config's own `rig` field.
std::vector<sim::RigPlacement> readCameraRig(const std::string& arg) {
  if (!std::filesystem::exists(arg) && arg.find_first_of("./") == std::string::npos)
    return sim::CameraSimConfig::rigPreset(arg);
  YAML::Node root = parseConfigYaml(readTextFile(arg), arg);
  if (root.IsMap() && root["rig"]) root = root["rig"];
  YAML::Node wrapped(YAML::NodeType::Map);
  wrapped["rig"] = root;
  sim::CameraSimConfig cameras;
  fieldsOf<sim::CameraSimConfig>().read(cameras, wrapped, ConfigPlace{arg, ""});
  fieldsOf<sim::CameraSimConfig>().check(cameras, ConfigPlace{arg, ""});
  if (cameras.rig.empty()) fail(arg, "rig lists no placement");
  return cameras.rig;
}

/// The --cameras family of options into the simulator config (over the config file's
/// `cameras:`; --cameras replaces its list, the others apply to the list in force).
void applyCameraOptions(const SimulateOptions& o, sim::CameraSimConfig& cameras) {
  if (!o.cameras.empty()) cameras.cameras = sim::CameraSimConfig::parseList(o.cameras);
  if (cameras.cameras.empty()) {
    if (!o.calibration_error.empty() || o.time_offset != 0.0 || o.camera_blur || !o.camera_size.empty() ||
        !o.camera_rig.empty())
      fail("simulate", "--calibration-error, --time-offset, --camera-blur, --camera-size and --camera-rig need --cameras");
    return;
  }
  if (!o.camera_rig.empty()) cameras.rig = readCameraRig(o.camera_rig);
  if (!o.calibration_error.empty()) cameras.parseCalibrationError(o.calibration_error);
  if (o.time_offset != 0.0) cameras.time_offset = o.time_offset;
  for (auto& c : cameras.cameras) {
    if (o.camera_blur) c.blur = true;
    if (!o.camera_size.empty()) {
      int w = 0, h = 0;
      char x = 0;
      std::istringstream in(o.camera_size);
      if (!(in >> w >> x >> h) || x != 'x' || !in.eof()) fail("--camera-size", "expected WIDTHxHEIGHT, e.g. 640x512");
      c.width = w;
      c.height = h;
    }
  }
}

void setupSimulate(CLI::App& app) {
  auto opt = std::make_shared<SimulateOptions>();
  auto* scenario = app.add_option("--scenario", opt->scenario,
                                  "Built-in scene: naraha (the paper's experiment), corridor, tanks");
  app.add_option("--out", opt->out, "Output sequence folder (must not exist or be empty)")->required();
  auto* seed = app.add_option("--seed", opt->seed, "Random seed; same seed, same bytes")
                   ->check(CLI::NonNegativeNumber);
  auto* frames = app.add_option("--frames", opt->frames, "Write only the first N frames (0 = whole route)")
                     ->check(CLI::NonNegativeNumber);
  app.add_option("--config", opt->config,
                 "Simulator config YAML (sensor, labels, temperature, robot, odometry sections; "
                 "command-line options given explicitly override it)");
  auto* scene = app.add_option("--scene", opt->scene, "User scene mesh (.ply) instead of a built-in scene");
  auto* regions = app.add_option("--regions", opt->regions, "Property regions and route of --scene (.yaml)");
  app.add_flag("--overwrite", opt->overwrite, "Replace --out if it exists and is not empty");
  auto* temperature = app.add_flag("--temperature", opt->temperature,
                                   "Also write the temperature channel (temperature/*.bin)");
  app.add_option("--format", opt->format,
                 "folder: a sequence folder; mcap: a ROS 2 MCAP bag (PointCloud2 with a class field, "
                 "Odometry, PoseStamped ground truth on /ground_truth) at --out; pcap: the VLP-16's data packets "
                 "(geometry only: no classes, odometry or truth) at --out")
      ->check(CLI::IsMember({"folder", "mcap", "pcap"}));
  app.add_flag("--png", opt->png,
               "Also render reference_map.png and odometry_map.png (top-down, classes coloured)");
  app.add_option("--cameras", opt->cameras,
                 "Also render property cameras (comma list of thermal, nir, gamma): "
                 "cameras/<name>/NNNNNN.png, times.txt, camera.yaml");
  app.add_option("--calibration-error", opt->calibration_error,
                 "Perturb the written camera calibration, e.g. 1deg,2cm (random axis and direction)");
  app.add_option("--time-offset", opt->time_offset, "Error (s) of the time_offset written to camera.yaml");
  app.add_flag("--camera-blur", opt->camera_blur, "Blur camera images by about one pixel");
  app.add_option("--camera-size", opt->camera_size, "Camera resolution WIDTHxHEIGHT (default 640x512, 50 deg HFOV)");
  app.add_option("--camera-rig", opt->camera_rig,
                 "Place every --cameras camera on a rig: ring4 (four 90 deg cameras, 360 deg), front-rear, or a "
                 "rig YAML (rig: [{name, yaw_deg, hfov_deg}]); cameras/<kind>_<place>/ and cameras/rig.yaml");
  app.add_option("--image-format", opt->image_format,
                 "--format mcap: cameras as sensor_msgs/Image mono16 (default) or sensor_msgs/CompressedImage png")
      ->check(CLI::IsMember({"mono16", "png"}));
  app.add_flag("--worst-day", opt->worst_day,
               "The crawler's worst day (preset worst-day): track slips up to 2 m, yaw kicks up to 45 deg, "
               "lost scans; --config keys override it");
  app.add_flag("--no-odometry", opt->no_odometry, "Write no odometry.txt (a run without wheel odometry)");
  app.add_option("--imu-rate", opt->imu_rate,
                 "Also write imu.txt: gyro + accelerometer samples at this rate (Hz, e.g. 200; noise: imu.* keys)")
      ->check(CLI::Range(1.0, 2000.0));
  app.add_flag("--closed-route", opt->closed_route,
               "Drive only the route's closed loop, back to the start heading at its end (simulator key "
               "closed_route): a capture replayed with hazmap replay --loop goes round without a jump");
  app.add_option("--mission", opt->mission,
                 "Mission K of a site entered again (1 = the scene with a crate; K >= 2 starts elsewhere on "
                 "the route, drives part of it, finds sources moved/removed/hotter, a new puddle and the crate "
                 "moved: changes_truth.json; poses.txt in mission 1's frame)")
      ->check(CLI::Range(1, 1000));
  app.callback([opt, scenario, seed, frames, scene, regions, temperature]() {
    sim::SimulatorConfig config;
    if (opt->worst_day) config = sim::SimulatorConfig::withPreset("worst-day", config, "--worst-day");
    if (!opt->config.empty()) config = sim::SimulatorConfig::fromYamlFile(opt->config, config);
    if (opt->no_odometry) config.wheel_odometry = false;
    if (opt->imu_rate > 0.0) config.imu.rate_hz = opt->imu_rate;
    if (scenario->count() || opt->config.empty()) config.scenario = opt->scenario;
    if (seed->count()) config.seed = opt->seed;
    if (frames->count()) config.max_frames = opt->frames;
    if (opt->closed_route) config.closed_route = true;
    if (scene->count()) config.scene_file = opt->scene;
    if (regions->count()) config.regions_file = opt->regions;
    if (temperature->count()) config.temperature.enabled = opt->temperature;
    applyCameraOptions(*opt, config.cameras);
    if (opt->image_format != "mono16" && opt->format != "mcap") fail("--image-format", "is for --format mcap");
    if (opt->mission > 0 && opt->format != "folder") fail("--mission", "writes a sequence folder, not --format " + opt->format);
    if (opt->mission > 1 && config.closed_route) fail("--closed-route", "drives the whole loop; a later --mission drives part of it");
    if (opt->format == "pcap") {
      if (opt->png) fail("--png", "renders a sequence folder; not with --format pcap");
      writeSimulationAsPcap(config, opt->out, opt->overwrite);
      return;
    }
    if (opt->format == "mcap") {
      if (opt->png) fail("--png", "renders a sequence folder; not with --format mcap");
      writeSimulationAsMcap(config, opt->out, opt->overwrite, opt->image_format == "png");
      return;
    }
    const auto summary = opt->mission > 0 ? writeMissionFolder(*opt, config)
                                          : sim::writeSimulation(config, opt->out, opt->overwrite);
    const double fps = summary.scan_seconds > 0.0 ? summary.frames / summary.scan_seconds : 0.0;
    std::cout << fmt::format(
        "wrote {}: {} frames, {:.1f} m route, {} points\n"
        "  BVH build {:.3f} s, scans {:.2f} s ({:.1f} frames/s), files {:.2f} s, reference map {:.2f} s, "
        "total {:.2f} s\n"
        "  odometry vs truth: mean position error {:.3f} m, max {:.3f} m, final {:.3f} m; "
        "worst frame {:.3f} m / {:.2f} deg; {} track slips\n",
        opt->out, summary.frames, summary.route_length, summary.points, summary.bvh_seconds,
        summary.scan_seconds, fps, summary.write_seconds, summary.reference_seconds, summary.total_seconds, summary.drift.mean_position_error,
        summary.drift.max_position_error, summary.drift.final_position_error,
        summary.drift.max_frame_translation_error, summary.drift.max_frame_rotation_error_deg,
        summary.drift.slips);
    if (!config.cameras.empty()) {
      std::string names;
      for (const auto& c : config.cameras.placedCameras()) names += (names.empty() ? "" : ",") + c.name;
      std::cout << fmt::format("  cameras ({}): {:.2f} s\n", names, summary.camera_seconds);
    }
    if (opt->png) {
      // Clip 0.5 m below the lowest ceiling of the built-in scenes (3 m) to see inside.
      renderPngs(opt->out, config.reference_voxel, config.scene_file.empty() ? 2.5 : 1e9);
      std::cout << "  rendered reference_map.png and odometry_map.png\n";
    }
  });
}

const RegisterCommand kRegister{{"simulate",
                                 "Simulate the paper's experiment: a crawler with a VLP-16 in a "
                                 "facility with heat sources and puddles; writes a sequence",
                                 setupSimulate}};

}  // namespace
}  // namespace hazmap::cli
