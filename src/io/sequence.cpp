#include "hazmap/io/sequence.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <system_error>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

namespace fs = std::filesystem;

bool isScan(const fs::path& p) {
  const std::string ext = io_detail::extensionOf(p);
  return ext == ".bin" || ext == ".pcd" || ext == ".ply";
}

std::optional<Trajectory> readOptionalTrajectory(const fs::path& path, std::size_t scans) {
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  Trajectory t = readKittiTrajectory(path);
  if (t.size() != scans)
    fail(path.string(), "has " + std::to_string(t.size()) + " poses but the sequence has " +
                            std::to_string(scans) + " scans (one line per scan expected)");
  return t;
}

/// The class table stored with a sequence: the classes without the raw-label mapping, because a
/// SequenceWriter stores class ids (not raw ids) in labels/*.label.
ClassTable withoutRawMapping(const ClassTable& table) {
  ClassTable out;
  for (ClassId id : table.ids()) out.add(table.at(id));
  out.mismatch_penalty = table.mismatch_penalty;
  return out;
}

std::string frameName(std::size_t i) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06zu", i);
  return buf;
}

// NAME/NNNNNN.bin: one float32 per point of the scan.
std::vector<float> readChannelFile(const fs::path& path, std::size_t points) {
  const std::string bytes = readTextFile(path);
  if (bytes.size() != points * sizeof(float))
    fail(path.string(), "has " + std::to_string(bytes.size()) + " bytes; the scan's " + std::to_string(points) +
                            " points need " + std::to_string(points * sizeof(float)));
  std::vector<float> values(points);
  if (points) std::memcpy(values.data(), bytes.data(), bytes.size());
  return values;
}

// hazmap.yaml's `channels:` list: folder names, each present, none twice.
std::vector<std::string> readChannelNames(const YAML::Node& node, const fs::path& dir, const std::string& where) {
  if (!node.IsSequence()) fail(where, "'channels' must be a list of channel (folder) names");
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& n : node) {
    const std::string name = n.IsScalar() ? n.as<std::string>() : std::string();
    if (name.empty() || name.find('/') != std::string::npos || name == "." || name == "..")
      fail(where, "'channels' must be a list of channel (folder) names");
    if (std::find(names.begin(), names.end(), name) != names.end()) fail(where, "channel '" + name + "' listed twice");
    if (!fs::is_directory(dir / name, ec)) fail(where, "channel '" + name + "' has no folder " + (dir / name).string());
    names.push_back(name);
  }
  return names;
}

// A channel's file for one scan: CHANNEL/<the scan's name>.bin beside velodyne/.
fs::path channelFile(const fs::path& dir, const std::string& channel, const fs::path& scan) {
  fs::path path = dir / channel / scan.filename();
  path.replace_extension(".bin");
  return path;
}

// A folder named no class table: labels with SemanticKITTI's ids (the first label file decides,
// read once) are meant for its table, not for hazmap's default classes 0-3.
std::optional<std::string> semanticKittiNote(const std::vector<std::optional<fs::path>>& labels) {
  const auto first = std::find_if(labels.begin(), labels.end(), [](const auto& l) { return l.has_value(); });
  if (first == labels.end()) return std::nullopt;
  if (!looksLikeSemanticKittiLabels(readSemanticKittiLabels(**first))) return std::nullopt;
  return (*first)->string() + " holds SemanticKITTI label ids: read with the semantic-kitti class table "
                              "(--classes to choose another)";
}

void checkFrameIndex(const fs::path& dir, std::size_t i, std::size_t frames) {
  if (i >= frames)
    fail(dir.string(), "frame " + std::to_string(i) + " out of range (" + std::to_string(frames) + " frames)");
}

}  // namespace

Sequence Sequence::open(const fs::path& dir, const std::optional<ClassTable>& table_override) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) fail(dir.string(), "sequence folder not found");
  if (!fs::is_directory(dir, ec)) fail(dir.string(), "is not a folder (expected a sequence directory)");
  const fs::path velodyne = dir / "velodyne";
  if (!fs::is_directory(velodyne, ec)) fail(dir.string(), "no velodyne/ folder (not a sequence directory)");
  Sequence seq;
  seq.dir_ = dir;
  for (const auto& entry : fs::directory_iterator(velodyne, ec))
    if (entry.is_regular_file() && isScan(entry.path())) seq.scans_.push_back(entry.path());
  if (ec) fail(velodyne.string(), "cannot list: " + ec.message());
  std::sort(seq.scans_.begin(), seq.scans_.end());
  for (const auto& scan : seq.scans_) {
    std::optional<fs::path> label;
    if (io_detail::extensionOf(scan) == ".bin") {
      fs::path l = dir / "labels" / scan.filename();
      l.replace_extension(".label");
      if (fs::is_regular_file(l, ec)) label = l;
    }
    seq.labels_.push_back(label);
  }

  bool table_named = table_override.has_value();
  const fs::path yaml_path = dir / "hazmap.yaml";
  if (fs::exists(yaml_path, ec)) {
    const std::string where = yaml_path.string();
    YAML::Node root;
    try {
      root = YAML::Load(readTextFile(yaml_path));
    } catch (const YAML::Exception& e) {
      fail(where, std::string("invalid YAML: ") + e.msg + " at line " + std::to_string(e.mark.line + 1));
    }
    if (root && !root.IsNull() && !root.IsMap()) fail(where, "must be a YAML mapping");
    if (root.IsMap()) {
      if (const YAML::Node t = root["class_table"]; t && !table_override) {
        table_named = true;
        if (t.IsScalar()) {
          // A built-in name or a path relative to the sequence folder.
          const std::string name = t.as<std::string>();
          const fs::path rel = dir / name;
          seq.table_ = (name == "default" || name == "semantic-kitti" || fs::path(name).is_absolute())
                           ? ClassTable::load(name)
                           : ClassTable::fromYamlFile(rel);
        } else if (t.IsMap()) {
          seq.table_ = ClassTable::fromYamlString(YAML::Dump(t), where + ": class_table");
        } else {
          fail(where, "'class_table' must be a table or the name/path of one");
        }
      }
      if (const YAML::Node s = root["sensor"]; s && !s.IsNull()) seq.sensor_yaml_ = YAML::Dump(s) + "\n";
      if (const YAML::Node p = root["property_channel"]; p) {
        if (!p.IsScalar() || p.as<std::string>().empty() || p.as<std::string>().find('/') != std::string::npos)
          fail(where, "'property_channel' must be a channel (folder) name");
        seq.property_channel_ = p.as<std::string>();
        if (!fs::is_directory(dir / seq.property_channel_, ec))
          fail(where, "property_channel '" + seq.property_channel_ + "' has no folder " +
                          (dir / seq.property_channel_).string());
        seq.channels_ = {seq.property_channel_};
      }
      if (const YAML::Node c = root["channels"]; c) seq.channels_ = readChannelNames(c, dir, where);
    }
  }
  if (table_override) seq.table_ = *table_override;
  if (!table_named)
    if (auto note = semanticKittiNote(seq.labels_)) {
      seq.table_ = ClassTable::semanticKitti();
      seq.table_note_ = std::move(*note);
    }
  seq.ground_truth_ = readOptionalTrajectory(dir / "poses.txt", seq.scans_.size());
  seq.odometry_ = readOptionalTrajectory(dir / "odometry.txt", seq.scans_.size());
  if (fs::exists(dir / "gravity.txt", ec)) seq.gravity_ = readGravityFile(dir / "gravity.txt", seq.scans_.size());
  if (fs::exists(dir / "imu.txt", ec)) {
    seq.imu_ = readImuFile(dir / "imu.txt");
    seq.imu_note_ = describe(cleanImuStream(seq.imu_, kImuMaxGap), (dir / "imu.txt").string());
  }
  return seq;
}

std::vector<PointChannel> Sequence::frameChannels(std::size_t i, std::size_t points) const {
  checkFrameIndex(dir_, i, scans_.size());
  std::vector<PointChannel> out;
  for (const std::string& name : channels_)
    out.push_back({name, readChannelFile(channelFile(dir_, name, scans_[i]), points)});
  return out;
}

LabeledCloud Sequence::frame(std::size_t i, ReadStats* stats) const {
  checkFrameIndex(dir_, i, scans_.size());
  LabeledCloud scan = io_detail::extensionOf(scans_[i]) == ".bin" ? readKittiScan(scans_[i], labels_[i], table_, stats)
                                                                    : readCloud(scans_[i], table_, stats);
  if (!property_channel_.empty()) readPropertyChannel(i, scan);
  return scan;
}

void Sequence::readPropertyChannel(std::size_t i, LabeledCloud& scan) const {
  std::vector<float> values = readChannelFile(channelFile(dir_, property_channel_, scans_[i]), scan.size());
  scan.enableProperty();
  scan.property = std::move(values);
}

SequenceWriter::SequenceWriter(fs::path dir, ClassTable table, std::string sensor_yaml)
    : dir_(std::move(dir)), table_(std::move(table)), sensor_yaml_(std::move(sensor_yaml)) {
  if (!sensor_yaml_.empty()) {
    try {
      (void)YAML::Load(sensor_yaml_);
    } catch (const YAML::Exception& e) {
      fail(dir_.string(), std::string("sensor description is not valid YAML: ") + e.msg);
    }
  }
  std::error_code ec;
  fs::create_directories(dir_ / "velodyne", ec);
  if (!ec) fs::create_directories(dir_ / "labels", ec);
  if (ec) fail(dir_.string(), "cannot create sequence folders: " + ec.message());
}

void SequenceWriter::setPropertyChannel(const std::string& name) {
  if (frames_ > 0) fail(dir_.string(), "property channel set after frames were written");
  property_channel_ = name;
  std::error_code ec;
  fs::create_directories(dir_ / name, ec);
  if (ec) fail(dir_.string(), "cannot create " + name + "/: " + ec.message());
}

void SequenceWriter::addFrame(const LabeledCloud& scan) {
  const std::string name = frameName(frames_);
  if (!property_channel_.empty()) {
    if (scan.property.size() != scan.size()) fail(dir_.string(), "frame " + name + " has no property channel");
    writeFileAtomically(dir_ / property_channel_ / (name + ".bin"), [&](std::ostream& out) {
      out.write(reinterpret_cast<const char*>(scan.property.data()),
                static_cast<std::streamsize>(scan.property.size() * sizeof(float)));
    });
  }
  writeKittiBin(dir_ / "velodyne" / (name + ".bin"), scan);
  writeSemanticKittiLabels(dir_ / "labels" / (name + ".label"), scan);
  ++frames_;
}

void SequenceWriter::writeGroundTruth(const Trajectory& poses) { writeKittiTrajectory(dir_ / "poses.txt", poses); }

void SequenceWriter::writeOdometry(const Trajectory& odometry) {
  writeKittiTrajectory(dir_ / "odometry.txt", odometry);
}

void SequenceWriter::finish() {
  YAML::Emitter out;
  out << YAML::Comment("hazmap sequence: labels/*.label hold hazmap class ids of this table");
  out << YAML::BeginMap;
  out << YAML::Key << "frames" << YAML::Value << frames_;
  out << YAML::Key << "class_table" << YAML::Value << YAML::Load(withoutRawMapping(table_).toYamlString());
  if (!sensor_yaml_.empty()) out << YAML::Key << "sensor" << YAML::Value << YAML::Load(sensor_yaml_);
  if (!property_channel_.empty()) out << YAML::Key << "property_channel" << YAML::Value << property_channel_;
  if (!channels_.empty()) out << YAML::Key << "channels" << YAML::Value << YAML::Flow << channels_;
  out << YAML::EndMap;
  writeTextAtomically(dir_ / "hazmap.yaml", std::string(out.c_str()) + "\n");
}

}  // namespace hazmap
