// hazmap run INPUT --method M --out DIR: the whole SLAM run and its outputs. INPUT is a sequence
// folder, a bag (ROS 1, rosbag2, MCAP) or a packet capture, read as a stream.
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <iostream>
#include <memory>

#include "command.hpp"
#include "config_options.hpp"
#include "hazmap/pipeline/progress.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/hazard_changes.hpp"
#include "hazmap/map/viewer.hpp"
#include "hazmap/pipeline/prior_map.hpp"
#include "hazmap/pipeline/run_outputs.hpp"
#include "recording.hpp"
#include "source_flags.hpp"
#include "hazmap/properties/label_sequence.hpp"

namespace hazmap::cli {
namespace {

struct RunOptions {
  std::string sequence;
  std::string method = "property-icp+pgo";
  std::string out;
  std::string config;
  std::string classes;
  int threads = 0;
  bool quiet = false;
  SourceFlags source;
  bool no_viewer = false;
  std::vector<std::string> cameras;  ///< camera.yaml (or rig) files: label from cameras first
  std::vector<std::string> image_topics;  ///< with a bag: one per camera
  std::string rules;
  std::string prior;  ///< map folder of an earlier run: localise in it (issue 34)
  bool start_unknown = false;  ///< hide the start pose: the run keeps its own frame (issue 34)
};

/// --prior: the earlier run's map, checked before any work (and never the output folder).
std::optional<MapFolder> openPrior(const RunOptions& o) {
  if (o.prior.empty()) return std::nullopt;
  std::error_code ec;
  if (std::filesystem::equivalent(o.prior, o.out, ec))
    fail("--prior", "is the output folder " + o.out + "; write the new run elsewhere");
  return openMap(o.prior);
}

/// run.json gains `key` (a JSON text) after the outputs were written.
void addToRunJson(const std::filesystem::path& out, const std::string& key, const std::string& json) {
  const std::filesystem::path run_json = out / "run.json";
  nlohmann::json j = nlohmann::json::parse(readTextFile(run_json));
  j[key] = nlohmann::json::parse(json);
  writeTextAtomically(run_json, j.dump(2) + "\n");
}

/// viewer.html again, from the folder, now with its changes layer (changes.json comes after the map).
void rewriteViewerWithChanges(const std::filesystem::path& out, const ClassTable& classes, const std::string& method) {
  ViewerScene scene = loadRunScene(out, classes);
  scene.title = "hazmap " + method;
  ViewerConfig viewer;
  viewer.decimate_to_fit = true;
  writeViewer(out / "viewer.html", scene, viewer);
}

/// With --camera, the sequence is first labelled from the cameras (hazmap label) into
/// <out>/labelled_sequence, and SLAM runs on that. A recording is first converted into
/// <out>/recording_sequence, and cameras with a `topic:` read their images from it.
std::string labelFromCameras(const RunOptions& o, LabelReport& report) {
  if (o.cameras.empty()) {
    if (!o.rules.empty() || !o.image_topics.empty()) fail("run", "--rules and --image-topic need --camera");
    return o.sequence;
  }
  LabelOptions options;
  for (const auto& c : o.cameras) options.cameras.emplace_back(c);
  options.image_topics = o.image_topics;
  options.rules = o.rules;
  options.overwrite = true;
  const std::filesystem::path out(o.out);
  std::filesystem::create_directories(out);
  std::filesystem::path input = o.sequence;
  if (isRecording(input)) {
    input = out / "recording_sequence";
    std::filesystem::remove_all(input);  // a previous run's
    convertRecording(o.sequence, input, o.source, true);
    options.image_bag = o.sequence;
  } else if (!o.image_topics.empty()) {
    fail("--image-topic", "needs a bag as input, not a folder");
  }
  const std::filesystem::path dir = out / "labelled_sequence";
  report = labelSequence(input, dir, options);
  if (!o.quiet)
    std::cout << fmt::format("labelled {} frames from {} camera(s): {:.1f} % of points observed, {:.1f} % with a "
                             "value after view fusion, {} missing images\n",
                             report.frames, o.cameras.size(),
                             report.points ? 100.0 * double(report.projection.observed) / double(report.points) : 0.0,
                             report.points ? 100.0 * double(report.valued) / double(report.points) : 0.0,
                             report.images_missing);
  return dir.string();
}

void run(const RunOptions& o, const ParameterOptions& params) {
  const SlamMethod method = parseSlamMethod(o.method);
  SlamConfig config = SlamConfig::forMethod(method);
  if (!o.config.empty()) config.applyYamlFile(o.config);
  // Parameter flags (config_options.hpp) override the file.
  config.property_icp = params.propertyIcp(config.property_icp);
  params.applySettings(config);
  config.threads = o.threads;
  std::optional<ClassTable> table;
  if (!o.classes.empty()) table = ClassTable::load(o.classes);
  config.deskew.enabled = !o.source.no_deskew;
  LabelReport labels;
  const std::string input = labelFromCameras(o, labels);
  ScanSourceOptions tracking_source = o.source.options(table, !o.quiet);
  tracking_source.read_channels = false;  // only the map (the second pass) keeps channels
  const std::optional<MapFolder> prior = openPrior(o);
  std::unique_ptr<ScanSource> scans = openScanSource(input, tracking_source);
  if (prior) checkPriorClasses(*prior, scans->classTable());
  // Where it starts is what the prior (or a later merge) must tell.
  if (prior || o.start_unknown) scans = startUnknown(std::move(scans));
  ProgressBar bar(o.method, scans->size().value_or(0), o.quiet ? 0 : -1);
  SlamResult result = runSlam(*scans, config, [&](std::size_t d, std::size_t) { bar.update(d); });
  bar.finish();
  std::optional<PriorLocalisation> localisation;
  if (prior) {
    const auto keyframe_pass = openScanSource(input, tracking_source);
    localisation = localiseInPrior(*prior, *keyframe_pass, result, config);
    for (const auto& w : localisation->warnings) std::cerr << "warning: --prior " << o.prior << ": " << w << "\n";
  }
  // The map is a second pass over the recording with the final poses.
  const auto second_pass = openScanSource(input, o.source.options(table));
  OutputConfig outputs;
  outputs.write_viewer = !o.no_viewer;
  outputs.channel_cameras = labels.channel_cameras;
  RunArtifacts artifacts;
  const RunSummary summary = writeRunOutputs(*second_pass, result, config, outputs, o.out, &artifacts);
  // What changed since the prior (only once the run is in its frame).
  std::size_t changed = 0;
  if (localisation && localisation->state == PriorState::Localised) {
    const auto changes = compareHazards(prior->hazards(), artifacts.hazards, artifacts.map);
    writeHazardChanges(o.out, changes);
    for (const auto& c : changes) changed += c.changed();
    if (outputs.write_viewer) rewriteViewerWithChanges(o.out, second_pass->classTable(), o.method);
  }
  // run.json gains the labelling's report (images missing, observed shares) and the prior's.
  if (!o.cameras.empty()) addToRunJson(o.out, "camera_labels", labelReportJson(labels));
  if (localisation) addToRunJson(o.out, "prior", priorJson(*localisation, o.prior));
  if (o.quiet) return;
  std::cout << formatRunSummary(result, summary, o.out, outputs);
  if (localisation) std::cout << formatPriorSummary(*localisation);
  if (localisation && localisation->state == PriorState::Localised)
    std::cout << fmt::format("Changes since the prior: {} (changes.json, changes.csv).\n", changed);
}

const RegisterCommand registration{{
    "run",
    "Run SLAM on a sequence directory, a bag or a packet capture and write trajectory, graph, map, "
    "hazards, PNGs and run.json",
    [](CLI::App& app) {
      auto o = std::make_shared<RunOptions>();
      app.add_option("sequence", o->sequence,
                     "Sequence directory (velodyne/, labels/, odometry.txt, ...), bag (.bag, .mcap, rosbag2 "
                     "folder) or capture (.pcap)")
          ->required();
      app.add_option("--method", o->method,
                     "odometry | icp | icp+pgo | property-icp | property-icp+pgo (the paper's Table 2 rows)");
      app.add_option("--out", o->out, "Output folder (created if missing)")->required();
      app.add_option("--config", o->config,
                     "YAML with sections odometry:, loop_closure:, graph:, slam:, wheel_noise: "
                     "(overrides the method's defaults)");
      app.add_option("--classes", o->classes,
                     "Class table: 'default', 'semantic-kitti' or a YAML file (overrides hazmap.yaml)");
      app.add_option("--threads", o->threads, "Worker threads (0 = all cores)");
      app.add_flag("--quiet", o->quiet, "No progress bar and no summary");
      o->source.add(app);
      app.add_flag("--no-viewer", o->no_viewer, "Do not write viewer.html (the map in 3D in a browser)");
      app.add_option("--camera", o->cameras,
                     "Label the scans from this calibrated camera first (camera.yaml; repeatable; see hazmap label)");
      app.add_option("--image-topic", o->image_topics,
                     "With a bag: the image topic of each --camera, in order (default: the camera YAML's topic:)");
      app.add_option("--rules", o->rules, "Class rules YAML for --camera (default: built-in rules)");
      app.add_option("--prior", o->prior,
                     "Map folder of an earlier run (its map.json): start unknown, localise in it, track and close "
                     "loops in its frame (run.json: prior)");
      app.add_flag("--start-unknown", o->start_unknown,
                   "Hide the ground truth's start pose and re-base the odometry: the run keeps its own frame, as a "
                   "mission entering without a map (to be placed later by hazmap merge)");
      auto params = addParameterOptions(app, "keys as in --config, e.g. odometry.registration.max_iterations=30");
      app.callback([o, params] { run(*o, *params); });
    }}};

}  // namespace
}  // namespace hazmap::cli
