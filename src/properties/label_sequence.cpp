#include "hazmap/properties/label_sequence.hpp"

#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/temporary_folder.hpp"
#include "hazmap/properties/bag_images.hpp"
#include "hazmap/properties/camera_rig.hpp"
#include "hazmap/properties/overlay.hpp"

namespace hazmap {

namespace fs = std::filesystem;

namespace {

std::optional<double> ratio(std::size_t num, std::size_t den) {
  if (den == 0) return std::nullopt;
  return static_cast<double>(num) / static_cast<double>(den);
}

}  // namespace

// Every property class now comes from a camera, which labels only what it saw of a region, so
// no class marks its whole extent (property ICP then keeps the class but not the labelled
// patch's outline, ClassInfo::whole_extent).
ClassTable cameraClassTable(const ClassTable& input) {
  ClassTable table = input;
  for (ClassId id : input.ids()) {
    ClassInfo info = input.at(id);
    if (!input.isProperty(id)) continue;
    info.whole_extent = false;
    table.add(info);
  }
  return table;
}

PropertyRules cameraRules(const fs::path& rules, const std::vector<std::string>& channels, const ClassTable& table) {
  PropertyRules r = rules.empty() ? PropertyRules::defaults(channels, table) : PropertyRules::fromYamlFile(rules, table);
  if (r.rules().empty())
    fail("label", "no built-in rule applies to the cameras' channels; give --rules RULES.yaml");
  if (!rules.empty()) r.checkChannels(channels, rules.string());
  return r;
}

std::optional<double> ClassLabelMetrics::precision() const { return ratio(true_positive, true_positive + false_positive); }
std::optional<double> ClassLabelMetrics::recall() const { return ratio(true_positive, true_positive + false_negative); }
std::optional<double> ClassLabelMetrics::observedFraction() const { return ratio(observed, true_points); }

namespace {

/// The camera files with rigs expanded, each with its --image-topic (empty = the YAML's topic:).
std::vector<std::pair<fs::path, std::string>> cameraFiles(const std::vector<fs::path>& cameras,
                                                          const std::vector<std::string>& topics) {
  if (!topics.empty() && topics.size() != cameras.size())
    fail("--image-topic", "give one per --camera (" + std::to_string(cameras.size()) + " cameras, " +
                              std::to_string(topics.size()) + " topics)");
  std::vector<std::pair<fs::path, std::string>> out;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const std::string topic = topics.empty() ? std::string() : topics[k];
    const std::vector<fs::path> files = expandCameraFiles({cameras[k]});
    if (!topic.empty() && (files.size() != 1 || files.front() != cameras[k]))
      fail(cameras[k].string(), "is a camera rig: its cameras name their own topic: (no --image-topic)");
    for (const fs::path& f : files) out.emplace_back(f, topic);
  }
  std::vector<fs::path> all;
  for (const auto& [f, t] : out) all.push_back(f);
  (void)expandCameraFiles(all);  // a camera given twice, also across rigs
  return out;
}

}  // namespace

PropertyLabeler makeLabeler(const std::vector<fs::path>& cameras, const fs::path& rules, const ClassTable& table,
                            const LabelerConfig& config, const fs::path& image_bag,
                            const std::vector<std::string>& image_topics) {
  if (cameras.empty()) fail("label", "no camera given (--camera CAM.yaml)");
  std::vector<CameraInput> inputs;
  std::vector<std::string> channels;
  for (const auto& [path, topic] : cameraFiles(cameras, image_topics)) {
    CameraInput in;
    in.camera = readCameraYaml(path);
    if (!topic.empty() && image_bag.empty()) fail("--image-topic", topic + ": images from a topic need a bag as input");
    if (!topic.empty()) in.camera.topic = topic;
    if (!image_bag.empty() && !in.camera.topic.empty() && (in.camera.images.empty() || !topic.empty())) {
      in.images = readBagImages(image_bag, in.camera);
    } else {
      const fs::path images = in.camera.images.empty() ? fs::absolute(path).parent_path() : in.camera.images;
      in.images = std::make_shared<FolderImages>(images);
    }
    channels.push_back(in.camera.channel.name);
    inputs.push_back(std::move(in));
  }
  return PropertyLabeler(std::move(inputs), cameraRules(rules, channels, table), config);
}

std::vector<double> readScanTimes(const Sequence& sequence) {
  const fs::path path = sequence.directory() / "times.txt";
  if (!fs::exists(path)) fail(path.string(), "missing: scan times are needed to match camera images");
  std::istringstream in(readTextFile(path));
  std::vector<double> times;
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      times.push_back(std::stod(line));
    } catch (const std::logic_error&) {
      fail(path.string(), "line " + std::to_string(times.size() + 1) + " is not a number");
    }
  }
  if (times.size() != sequence.size())
    fail(path.string(), "has " + std::to_string(times.size()) + " times for " + std::to_string(sequence.size()) + " scans");
  return times;
}

namespace {

/// The classes that judge the camera labels: the simulator's noise-free labels_true/ when
/// present, else labels/ (what the scans carry); none without labels.
std::string truthSource(const fs::path& dir) {
  if (fs::is_directory(dir / "labels_true")) return "labels_true";
  if (fs::is_directory(dir / "labels") && !fs::is_empty(dir / "labels")) return "labels";
  return "";
}

std::vector<ClassId> truthOf(const Sequence& seq, std::size_t i, const LabeledCloud& scan, const std::string& source) {
  if (source != "labels_true") return scan.classes;
  fs::path path = seq.directory() / "labels_true" / seq.scanPath(i).filename();
  path.replace_extension(".label");
  const auto raw = readSemanticKittiLabels(path);
  if (raw.size() != scan.size())
    fail(path.string(), "has " + std::to_string(raw.size()) + " labels for " + std::to_string(scan.size()) + " points");
  std::vector<ClassId> out(raw.size());
  for (std::size_t k = 0; k < raw.size(); ++k) out[k] = static_cast<ClassId>(raw[k] & 0xFFFF);
  return out;
}

/// Counts for the classes the rules can give (the others are not the cameras' business).
void accumulate(const ScanLabels& labels, const std::vector<ClassId>& truth, const PropertyRules& rules,
                const ClassTable& table, LabelReport& report) {
  std::vector<ClassId> ruled;
  for (const ClassRule& r : rules.rules())
    if (std::find(ruled.begin(), ruled.end(), r.class_id) == ruled.end()) ruled.push_back(r.class_id);
  for (ClassId id : ruled) {
    ClassLabelMetrics& m = report.classes[table.at(id).name];
    for (std::size_t i = 0; i < truth.size(); ++i) {
      const bool is = truth[i] == id, said = labels.classes[i] == id;
      if (is) {
        ++m.true_points;
        for (const auto& ch : labels.channels)
          if (std::isfinite(ch[i])) {
            ++m.observed;
            break;
          }
      }
      if (!labels.in_view[i]) continue;
      m.true_positive += is && said;
      m.false_positive += !is && said;
      m.false_negative += is && !said;
    }
  }
}

bool observedByAnyChannel(const ScanLabels& labels, std::size_t k) {
  for (const auto& ch : labels.channels)
    if (std::isfinite(ch[k])) return true;
  return false;
}

/// Per class, the channels its rules read (normal_z aside): only they can give the class.
std::map<ClassId, std::vector<std::size_t>> channelsOfClasses(const PropertyLabeler& labeler) {
  std::map<ClassId, std::vector<std::size_t>> out;
  const auto& channels = labeler.channels();
  for (const ClassRule& r : labeler.rules().rules())
    for (const std::string& v : r.expression.variables()) {
      const auto at = std::find(channels.begin(), channels.end(), v);
      if (at != channels.end()) out[r.class_id].push_back(static_cast<std::size_t>(at - channels.begin()));
    }
  return out;
}

/// Oracle labels: the input's classes where a camera observed the point (per_class: a camera
/// whose channel the class's rules read), `none` elsewhere.
void replaceByOracle(const std::vector<ClassId>& input, const std::map<ClassId, std::vector<std::size_t>>* per_class,
                     ScanLabels& labels) {
  for (std::size_t k = 0; k < labels.classes.size(); ++k) {
    bool seen = false;
    if (!per_class) {
      seen = observedByAnyChannel(labels, k);
    } else if (const auto it = per_class->find(input[k]); it != per_class->end()) {
      for (std::size_t c : it->second) seen = seen || std::isfinite(labels.channels[c][k]);
    }
    labels.classes[k] = seen ? input[k] : ClassId{0};
  }
}

void copyIfExists(const fs::path& from, const fs::path& to) {
  if (fs::exists(from)) fs::copy_file(from, to, fs::copy_options::overwrite_existing);
}

}  // namespace

namespace {

/// What one labelled frame leaves behind: the labels and where they go.
struct FrameSink {
  const Sequence& seq;
  const PropertyLabeler& labeler;
  const fs::path& dir;
  SequenceWriter& writer;
  LabelReport& report;
  bool oracle = false;
  const std::map<ClassId, std::vector<std::size_t>>* oracle_per_class = nullptr;

  void operator()(std::size_t i, LabeledCloud& scan, ScanLabels& l) const {
    if (oracle) replaceByOracle(scan.classes, oracle_per_class, l);
    if (!report.truth_source.empty())
      accumulate(l, truthOf(seq, i, scan, report.truth_source), labeler.rules(), seq.classTable(), report);
    for (std::size_t c = 1; c < l.channels.size(); ++c) {
      const fs::path channel_dir = dir / labeler.channels()[c];
      fs::create_directories(channel_dir);
      char name[32];
      std::snprintf(name, sizeof name, "%06zu.bin", i);
      writeFileAtomically(channel_dir / name, [&](std::ostream& o) {
        o.write(reinterpret_cast<const char*>(l.channels[c].data()), static_cast<std::streamsize>(l.channels[c].size() * 4));
      });
    }
    for (std::size_t k = 0; k < scan.size(); ++k) report.valued += observedByAnyChannel(l, k);
    for (std::uint8_t v : l.in_view) report.in_view_points += v;
    PropertyLabeler::apply(l, scan);
    writer.addFrame(scan);
    report.points += scan.size();
    report.projection += l.projection;
    report.images_missing += l.images_missing;
  }
};

/// Runs `step(i, scan)` over the frames in parallel batches (bounded memory), then `done(i,
/// scan)` in frame order.
template <class Step, class Done>
void forEachFrame(const Sequence& seq, Step step, Done done) {
  const std::size_t batch = 16;
  std::vector<LabeledCloud> scans;
  for (std::size_t begin = 0; begin < seq.size(); begin += batch) {
    const std::size_t end = std::min(seq.size(), begin + batch);
    scans.assign(end - begin, {});
    tbb::parallel_for(begin, end, [&](std::size_t i) {
      scans[i - begin] = seq.frame(i);
      step(i, scans[i - begin]);
    });
    for (std::size_t i = begin; i < end; ++i) done(i, scans[i - begin]);
  }
}

/// Each scan from its own images only.
void labelEachScan(const Sequence& seq, const std::vector<double>& times, const PropertyLabeler& labeler,
                   const PoseAtTime& pose_at, const FrameSink& sink) {
  std::vector<ScanLabels> labels(seq.size());
  forEachFrame(
      seq, [&](std::size_t i, const LabeledCloud& scan) { labels[i] = labeler.label(scan, times[i], pose_at); },
      [&](std::size_t i, LabeledCloud& scan) {
        sink(i, scan, labels[i]);
        labels[i] = {};
      });
}

/// Pass 1 records every scan's views, pass 2 samples each point in its voxel's best view nearby.
void labelWithFusion(const Sequence& seq, const std::vector<double>& times, const PropertyLabeler& labeler,
                     const PoseAtTime& pose_at, const Trajectory& placement, const ViewFusionConfig& config,
                     const FrameSink& sink) {
  const std::vector<double> travelled = travelledDistance(placement);
  ViewFusion fusion(labeler, config);
  std::vector<ScanLabels> observed(seq.size());
  forEachFrame(
      seq, [&](std::size_t i, const LabeledCloud& scan) { observed[i] = labeler.observe(scan, times[i], pose_at); },
      [&](std::size_t i, const LabeledCloud& scan) {
        fusion.add(i, scan, placement.poses[i], travelled[i], observed[i]);
        observed[i].footprint = {};
        observed[i].normals = {};
      });
  std::vector<std::vector<std::int32_t>> best(seq.size());
  forEachFrame(
      seq, [&](std::size_t i, const LabeledCloud& scan) { best[i] = fusion.bestFrames(i, scan); },
      [&](std::size_t i, LabeledCloud& scan) {
        ScanLabels& l = observed[i];
        fusion.fuse(i, scan, best[i], l);
        labeler.classify(scan, pose_at ? pose_at(times[i]) : std::nullopt, l);
        sink(i, scan, l);
        l = {};
        best[i] = {};
      });
}

}  // namespace

LabelReport labelSequence(const fs::path& sequence_dir, const fs::path& out_arg, const LabelOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const Sequence seq = Sequence::open(sequence_dir);
  const std::vector<double> times = readScanTimes(seq);
  LabelerConfig labeler_config = options.labeler;
  labeler_config.footprints = options.fuse_views;
  const PropertyLabeler labeler =
      makeLabeler(options.cameras, options.rules, seq.classTable(), labeler_config, options.image_bag, options.image_topics);
  if (out_arg.empty()) fail("label", "no output folder given (--out)");
  options.fusion.validate("label");
  fs::path out = fs::absolute(out_arg).lexically_normal();
  if (!out.has_filename()) out = out.parent_path();
  if (out == fs::absolute(sequence_dir).lexically_normal()) fail(out_arg.string(), "is the input sequence");
  const bool replace = checkSequenceOutput(out, out_arg.string(), options.overwrite);

  // Poses place each image where the LiDAR was when it was taken and the scans in the world
  // for view fusion: the odometry (what the robot knows), else the ground truth.
  Trajectory poses;
  if (const auto& t = seq.odometry() ? seq.odometry() : seq.groundTruth())
    for (std::size_t i = 0; i < t->size(); ++i) poses.push_back(times[i], t->poses[i]);
  const PoseAtTime pose_at = poses.empty() ? PoseAtTime{} : [&](double t) { return interpolatePose(poses, t); };

  LabelReport report;
  report.channels = labeler.channels();
  for (std::size_t c = 0; c < labeler.cameras().size(); ++c)
    report.channel_cameras[labeler.channels()[static_cast<std::size_t>(labeler.cameraChannel(c))]].push_back(
        labeler.cameras()[c].camera.name);
  report.truth_source = truthSource(sequence_dir);
  TemporaryFolder tmp{temporarySibling(out)};
  fs::create_directories(tmp.path);
  SequenceWriter writer(tmp.path, cameraClassTable(seq.classTable()), seq.sensorYaml());
  writer.setPropertyChannel(labeler.channels().front());
  writer.setChannels(labeler.channels());
  const auto per_class = channelsOfClasses(labeler);
  const FrameSink sink{seq, labeler, tmp.path, writer, report, options.oracle_labels,
                       options.oracle_per_channel ? &per_class : nullptr};
  report.fused = options.fuse_views && poses.size() == seq.size();
  if (report.fused)
    labelWithFusion(seq, times, labeler, pose_at, poses, options.fusion, sink);
  else
    labelEachScan(seq, times, labeler, pose_at, sink);
  report.frames = seq.size();
  if (seq.groundTruth()) writer.writeGroundTruth(*seq.groundTruth());
  if (seq.odometry()) writer.writeOdometry(*seq.odometry());
  writer.finish();
  copyIfExists(sequence_dir / "times.txt", tmp.path / "times.txt");
  // gravity.txt and imu.txt: the recording's IMU (the AHRS's direction per scan, the raw samples
  // on the scans' clock): a run on the labelled sequence deskews, guesses and has gravity as on the
  // recording.
  for (const char* f : {"reference_map.ply", "scene.ply", "regions.yaml", "gravity.txt", "imu.txt"})
    copyIfExists(sequence_dir / f, tmp.path / f);
  if (report.truth_source == "labels_true") fs::copy(sequence_dir / "labels_true", tmp.path / "labels_true");
  writeTextAtomically(tmp.path / "labels.json", labelReportJson(report));
  commitFolder(tmp, out, out_arg.string(), replace);
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return report;
}

void writeLabelOverlays(const fs::path& labelled_dir, const std::vector<fs::path>& cameras, std::size_t frame,
                        const LabelerConfig& config) {
  const Sequence seq = Sequence::open(labelled_dir);
  if (frame >= seq.size()) fail("--overlay", "frame " + std::to_string(frame) + " is beyond the sequence");
  const double t = readScanTimes(seq).at(frame);
  const LabeledCloud scan = seq.frame(frame);
  fs::create_directories(labelled_dir / "overlays");
  for (const fs::path& path : expandCameraFiles(cameras)) {
    const CameraCalibration cam = readCameraYaml(path);
    const FolderImages images(cam.images.empty() ? fs::absolute(path).parent_path() : cam.images);
    const auto& stamps = images.stamps();
    std::size_t best = 0;
    for (std::size_t k = 1; k < stamps.size(); ++k)
      if (std::abs(stamps[k] + cam.time_offset - t) < std::abs(stamps[best] + cam.time_offset - t)) best = k;
    if (std::abs(stamps[best] + cam.time_offset - t) > config.time_tolerance) continue;
    OverlayConfig overlay;
    if (cam.channel.name != "temperature") {  // reflectance, dose rate: their own ranges
      overlay.value_min = 0.0;
      overlay.value_max = cam.channel.name == "nir_reflectance" ? 1.0 : 60.0;
    }
    char name[64];
    std::snprintf(name, sizeof name, "_%06zu.png", frame);
    writeOverlayPng(labelled_dir / "overlays" / (cam.name + name), images.load(best, cam), cam, scan, cam.T_camera_lidar,
                    seq.classTable(), config.projection, overlay);
  }
}

std::string labelReportJson(const LabelReport& r) {
  const auto opt = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  nlohmann::json j;
  j["frames"] = r.frames;
  j["points"] = r.points;
  j["channels"] = r.channels;
  j["channel_cameras"] = r.channel_cameras;
  j["in_view_fraction"] = opt(ratio(r.in_view_points, r.points));  // any camera's image
  j["observed_fraction"] = opt(ratio(r.projection.observed, r.points));
  j["occluded"] = r.projection.occluded;
  j["images_missing"] = r.images_missing;
  j["valued_fraction"] = opt(ratio(r.valued, r.points));
  j["view_fusion"] = r.fused;
  j["truth"] = r.truth_source.empty() ? nlohmann::json() : nlohmann::json(r.truth_source);
  nlohmann::json classes = nlohmann::json::object();
  for (const auto& [name, m] : r.classes)
    classes[name] = {{"precision", opt(m.precision())},
                     {"recall", opt(m.recall())},
                     {"observed_fraction", opt(m.observedFraction())},
                     {"true_points", m.true_points},
                     {"true_positive", m.true_positive},
                     {"false_positive", m.false_positive},
                     {"false_negative", m.false_negative}};
  j["labels"] = classes;
  return j.dump(2) + "\n";
}

}  // namespace hazmap
