#pragma once
// The simulator of the paper's experiment: a crawler with a VLP-16 driving through a facility
// with heat sources and puddles. One config struct (documented defaults, loadable from YAML),
// a Simulator that makes frames on demand (thread-safe, deterministic per frame), and
// writeSimulation() that writes the whole sequence directory.
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/config_fwd.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/sim/camera_sim.hpp"
#include "hazmap/sim/imu.hpp"
#include "hazmap/sim/lidar.hpp"
#include "hazmap/sim/odometry_noise.hpp"
#include "hazmap/sim/raycaster.hpp"
#include "hazmap/sim/route.hpp"
#include "hazmap/sim/scene.hpp"

namespace hazmap::sim {

using PoseList = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

struct SimulatorConfig {
  /// A named set-up applied before the other keys: "none" or "worst-day" (the crawler's worst
  /// day: track slips up to 2 m, yaw kicks up to 45°, lost scans; see worstDay()).
  std::string preset = "none";
  /// Built-in scene name (naraha, corridor, tanks); ignored when scene_file is set.
  std::string scenario = "naraha";
  std::string scene_file;    ///< user scene mesh (.ply); needs regions_file
  std::string regions_file;  ///< user regions + route (.yaml)
  std::string class_table = "default";  ///< "default", "semantic-kitti" or a YAML path
  std::uint64_t seed = 1;
  std::size_t max_frames = 0;  ///< 0 = the whole route
  /// Drive only the route's closed loop and turn back to the start heading at its end, so a
  /// capture replayed with `hazmap replay --loop` goes round without a jump (sim/route.hpp).
  bool closed_route = false;
  LidarConfig sensor;
  LabelNoiseConfig labels;
  TemperatureConfig temperature;
  RobotConfig robot;
  OdometryNoiseConfig odometry;
  CrawlerUpsetConfig upsets;  ///< true motion the encoders miss (off by default)
  bool wheel_odometry = true;  ///< false: the sequence has no odometry.txt
  ImuConfig imu;               ///< gravity.txt: the AHRS's gravity direction per scan
  double reference_voxel = 0.1;  ///< m, voxel size of reference_map.ply
  /// Property cameras (none by default; `hazmap simulate --cameras thermal,nir,gamma`).
  CameraSimConfig cameras;

  /// The presets `preset:` names: "worst-day" sets odometry slips (10 % of frames, 0.5–2 m),
  /// yaw kicks (10 %, 10–45°) and lost scans (10 %) on top of `base`.
  static SimulatorConfig withPreset(const std::string& name, SimulatorConfig base, const std::string& where);
  /// Reads a YAML file; unknown keys are errors (typos must not silently use defaults).
  /// Keys missing from the file keep the values already in `base`.
  static SimulatorConfig fromYamlFile(const std::filesystem::path& path,
                                      const SimulatorConfig& base);
  static SimulatorConfig fromYamlFile(const std::filesystem::path& path);
  static SimulatorConfig fromYamlString(const std::string& yaml, const std::string& where,
                                        const SimulatorConfig& base);
  static SimulatorConfig fromYamlString(const std::string& yaml, const std::string& where);
  std::string toYamlString() const;
  /// The `sensor:` section of hazmap.yaml (the VLP-16 model with its channel elevations).
  std::string sensorYaml() const;
  /// Throws hazmap::Error("<where>: <parameter> ...") for any invalid value.
  void validate(const std::string& where = "simulator config") const;
};

/// Field tables (keys, ranges, docs; core/config_fields.hpp, docs/configuration.md).
const ConfigFields<LidarConfig>& configFields(ConfigTag<LidarConfig>);
const ConfigFields<LabelNoiseConfig>& configFields(ConfigTag<LabelNoiseConfig>);
const ConfigFields<TemperatureConfig>& configFields(ConfigTag<TemperatureConfig>);
const ConfigFields<RobotConfig>& configFields(ConfigTag<RobotConfig>);
const ConfigFields<OdometryNoiseConfig>& configFields(ConfigTag<OdometryNoiseConfig>);
const ConfigFields<CrawlerUpsetConfig>& configFields(ConfigTag<CrawlerUpsetConfig>);
const ConfigFields<ImuConfig>& configFields(ConfigTag<ImuConfig>);
const ConfigFields<SimulatorConfig>& configFields(ConfigTag<SimulatorConfig>);

/// The scene a config asks for (built-in or loaded), validated against `table`.
Scene loadConfiguredScene(const SimulatorConfig& config, const ClassTable& table);

class Simulator {
 public:
  /// Validates everything and builds the BVH; throws hazmap::Error before any work on bad input.
  explicit Simulator(const SimulatorConfig& config);
  /// `truth_origin` (world ← frame): groundTruth() and odometry() in that frame instead of the
  /// first scan's (a later mission's poses in mission 1's frame, sim/missions.hpp).
  Simulator(const SimulatorConfig& config, Scene scene, ClassTable table,
            std::optional<Eigen::Isometry3d> truth_origin = std::nullopt);

  std::size_t frames() const { return truth_.size(); }
  /// Scan i in the sensor frame (thread-safe; same bytes for the same seed and index).
  /// `true_classes` receives the noise-free classes.
  LabeledCloud scan(std::size_t i, std::vector<ClassId>* true_classes = nullptr) const;
  /// True sensor poses (poses.txt), KITTI convention: in the frame of the first scan, so
  /// groundTruth()[0] is the identity.
  const PoseList& groundTruth() const { return truth_; }
  /// Accumulated encoder odometry (odometry.txt) in the same frame, also starting at identity.
  const PoseList& odometry() const { return odometry_; }
  /// True sensor poses in the scene's (world) frame: worldPoses()[i] = worldFromFirst() ·
  /// groundTruth()[i].
  const PoseList& worldPoses() const { return world_; }
  /// The first scan's pose in the scene frame (maps poses.txt / reference_map.ply to scene.ply).
  const Eigen::Isometry3d& worldFromFirst() const { return world_.front(); }
  /// Frame i's gravity measurement (config().imu; same value for the same seed and index).
  GravitySample gravity(std::size_t i) const;
  /// Whether a track slip happened between frame i-1 and i.
  const std::vector<bool>& slips() const { return slips_; }
  /// The yaw kick (rad, unseen by the encoders) between frame i-1 and i; empty without upsets.
  const std::vector<double>& yawKicks() const { return kicks_; }
  const std::vector<RouteSample>& samples() const { return samples_; }
  const Scene& scene() const { return scene_; }
  const ClassTable& classTable() const { return table_; }
  const SimulatorConfig& config() const { return config_; }
  double bvhBuildSeconds() const { return caster_->buildSeconds(); }
  /// The scene's ray caster (thread-safe), e.g. for rendering camera images.
  const RayCaster& caster() const { return *caster_; }
  /// Path length driven up to the last frame (m).
  double routeLength() const { return samples_.empty() ? 0.0 : samples_.back().travelled; }

 private:
  void init();
  SimulatorConfig config_;
  std::optional<Eigen::Isometry3d> truth_origin_;
  Scene scene_;
  ClassTable table_;
  std::unique_ptr<RayCaster> caster_;
  std::vector<Eigen::Vector3f> directions_;
  std::vector<RouteSample> samples_;
  PoseList world_, truth_, odometry_;
  std::vector<bool> slips_;
  std::vector<double> kicks_;
  ScanInputs inputs_;
};

/// Odometry-vs-truth statistics of a sequence (both start at the same pose).
struct OdometryDrift {
  double mean_position_error = 0.0;  ///< m, mean over frames of |t_odo - t_true|
  double max_position_error = 0.0;   ///< m
  double final_position_error = 0.0; ///< m, at the last frame
  double max_frame_translation_error = 0.0;  ///< m, worst per-frame increment error
  double max_frame_rotation_error_deg = 0.0; ///< °, worst per-frame increment error
  std::size_t slips = 0;
};
OdometryDrift odometryDrift(const PoseList& truth, const PoseList& odometry,
                            const std::vector<bool>& slips = {});

struct SimulationSummary {
  std::size_t frames = 0;
  std::size_t points = 0;
  double route_length = 0.0;
  double bvh_seconds = 0.0;
  double scan_seconds = 0.0;  ///< generating the scans (excluding the BVH and file writing)
  double write_seconds = 0.0;      ///< writing scans, labels and trajectories
  double reference_seconds = 0.0;  ///< building and writing reference_map.ply
  double camera_seconds = 0.0;     ///< rendering and writing camera images
  double total_seconds = 0.0;
  OdometryDrift drift;
};

/// Writes the sequence directory `out_dir`: velodyne/*.bin, labels/*.label, poses.txt,
/// odometry.txt, times.txt, gravity.txt (unless imu.enabled is false), hazmap.yaml, reference_map.ply, scene.ply, simulation.yaml (the
/// effective config), with the temperature channel on temperature/*.bin and with cameras
/// cameras/<name>/{NNNNNN.png, times.txt, camera.yaml}. Everything is
/// written into a temporary sibling folder that is renamed to `out_dir` at the end, so a
/// failure leaves no half-written sequence. `out_dir` must not exist or be empty; with
/// `overwrite` a previous sequence (a folder with hazmap.yaml or velodyne/) is replaced, never
/// any other folder. Validation happens before anything is created.
SimulationSummary writeSimulation(const SimulatorConfig& config, const std::filesystem::path& out_dir,
                                  bool overwrite = false);
/// The same for a simulator made already; `extra` writes more files into the folder before it is
/// renamed into place (a mission's changes_truth.json).
SimulationSummary writeSimulation(const Simulator& sim, const std::filesystem::path& out_dir, bool overwrite,
                                  const std::function<void(const std::filesystem::path& folder)>& extra);

}  // namespace hazmap::sim
