#pragma once
// A sequence directory (SemanticKITTI-compatible layout):
//   velodyne/NNNNNN.bin | .pcd | .ply   scans, sorted by name
//   labels/NNNNNN.label                  optional per-point labels (for .bin scans); without a
//                                        class table (hazmap.yaml, override) labels holding
//                                        SemanticKITTI ids are read with its table (tableNote())
//   poses.txt                            optional ground truth, KITTI format, one line per scan
//   odometry.txt                         optional wheel odometry, KITTI format, one line per scan
//   gravity.txt                          optional IMU gravity direction per scan (io/gravity.hpp)
//   imu.txt                              optional raw IMU samples, gyro + accelerometer (io/imu.hpp)
//   hazmap.yaml                          optional: `class_table:` (a class table), `sensor:` and
//                                        `property_channel: NAME` (then NAME/NNNNNN.bin holds one
//                                        float32 per point: LabeledCloud::property, NaN = unobserved)
//                                        and `channels: [NAME, …]` (every named channel folder,
//                                        the property channel first: Sequence::frameChannels)
// Frames are read lazily, one at a time.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/gravity.hpp"
#include "hazmap/io/imu.hpp"
#include "hazmap/io/read_stats.hpp"
#include "hazmap/io/trajectory.hpp"

namespace hazmap {

/// One named per-point channel of a scan (temperature, nir_reflectance, dose_rate, …): one value
/// per point of the scan, in its order; NaN = not observed.
struct PointChannel {
  std::string name;
  std::vector<float> values;
};

class Sequence {
 public:
  /// Scans the folder (does not read any scan). `table_override` replaces hazmap.yaml's table.
  static Sequence open(const std::filesystem::path& dir,
                       const std::optional<ClassTable>& table_override = std::nullopt);

  std::size_t size() const { return scans_.size(); }
  /// Reads frame i (labels mapped through classTable()). Throws hazmap::Error naming the file.
  LabeledCloud frame(std::size_t i, ReadStats* stats = nullptr) const;
  const std::filesystem::path& scanPath(std::size_t i) const { return scans_.at(i); }

  const std::filesystem::path& directory() const { return dir_; }
  const ClassTable& classTable() const { return table_; }
  /// Why classTable() is not the default one when nothing named a table (a SemanticKITTI
  /// sequence recognised by its first label file); empty otherwise. One line, for a notice.
  const std::string& tableNote() const { return table_note_; }
  const std::optional<Trajectory>& groundTruth() const { return ground_truth_; }
  const std::optional<Trajectory>& odometry() const { return odometry_; }
  /// gravity.txt, one sample per scan; nullopt without the file (no gravity information).
  const std::optional<std::vector<GravitySample>>& gravity() const { return gravity_; }
  /// imu.txt's samples in time order (out-of-order ones dropped: imuNote()); empty without it.
  const std::vector<ImuSample>& imu() const { return imu_; }
  /// What cleaning imu.txt dropped or found missing, one line; empty when clean.
  const std::string& imuNote() const { return imu_note_; }
  /// The `sensor:` section of hazmap.yaml as YAML text (empty if none).
  const std::string& sensorYaml() const { return sensor_yaml_; }
  /// hazmap.yaml's `property_channel` (empty if none): frames then carry the property channel.
  const std::string& propertyChannel() const { return property_channel_; }
  /// hazmap.yaml's `channels` (else just the property channel, else none).
  const std::vector<std::string>& channels() const { return channels_; }
  /// Frame i's named channels (channels() order), each checked against the scan's `points`.
  std::vector<PointChannel> frameChannels(std::size_t i, std::size_t points) const;

 private:
  void readPropertyChannel(std::size_t i, LabeledCloud& scan) const;
  std::filesystem::path dir_;
  std::vector<std::filesystem::path> scans_;
  std::vector<std::optional<std::filesystem::path>> labels_;
  ClassTable table_ = ClassTable::defaults();
  std::string table_note_;
  std::optional<Trajectory> ground_truth_, odometry_;
  std::optional<std::vector<GravitySample>> gravity_;
  std::vector<ImuSample> imu_;
  std::string imu_note_;
  std::string sensor_yaml_;
  std::string property_channel_;
  std::vector<std::string> channels_;
};

/// Writes a sequence directory frame by frame (velodyne/*.bin + labels/*.label), then the
/// trajectories and hazmap.yaml. Every file is written atomically.
class SequenceWriter {
 public:
  SequenceWriter(std::filesystem::path dir, ClassTable table, std::string sensor_yaml = "");
  void addFrame(const LabeledCloud& scan);
  /// From now on addFrame() also writes scan.property to NAME/NNNNNN.bin (scans must carry it)
  /// and finish() records `property_channel: NAME`. Call before the first addFrame().
  void setPropertyChannel(const std::string& name);
  /// finish() records `channels: [...]`: every channel folder the caller writes (NAME/NNNNNN.bin,
  /// one float32 per point), the property channel first.
  void setChannels(std::vector<std::string> names) { channels_ = std::move(names); }
  void writeGroundTruth(const Trajectory& poses);
  void writeOdometry(const Trajectory& odometry);
  /// Writes hazmap.yaml; call last.
  void finish();
  std::size_t frames() const { return frames_; }

 private:
  std::filesystem::path dir_;
  ClassTable table_;
  std::string sensor_yaml_;
  std::string property_channel_;
  std::vector<std::string> channels_;
  std::size_t frames_ = 0;
};

}  // namespace hazmap
