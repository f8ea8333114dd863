// A sequence folder (io/sequence.hpp) as a ScanSource: frames are read one at a time.
#include <fstream>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/scan_source.hpp"
#include "sources/imu_attach.hpp"

namespace hazmap {

namespace {

/// times.txt: one time (s) per scan; anything else (missing, wrong count) → the frame index.
std::vector<double> readScanTimes(const std::filesystem::path& dir, std::size_t scans) {
  std::ifstream in(dir / "times.txt");
  std::vector<double> times;
  if (in) {
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      double t = 0.0;
      if (fields >> t) times.push_back(t);
    }
  }
  if (times.size() == scans) return times;
  times.resize(scans);
  for (std::size_t i = 0; i < scans; ++i) times[i] = static_cast<double>(i);
  return times;
}

class SequenceSource final : public ScanSource {
 public:
  SequenceSource(Sequence sequence, bool read_channels)
      : sequence_(std::move(sequence)),
        times_(readScanTimes(sequence_.directory(), sequence_.size())),
        read_channels_(read_channels) {}

  std::optional<Scan> next() override {
    if (next_ >= sequence_.size()) return std::nullopt;
    Scan scan;
    scan.index = next_;
    scan.stamp = times_[next_];
    scan.cloud = sequence_.frame(next_);
    if (read_channels_ && !sequence_.channels().empty()) scan.channels = sequence_.frameChannels(next_, scan.cloud.size());
    if (const auto& odometry = sequence_.odometry()) scan.odometry = odometry->poses[next_];
    if (const auto& truth = sequence_.groundTruth()) scan.ground_truth = truth->poses[next_];
    if (const auto& gravity = sequence_.gravity()) scan.gravity = (*gravity)[next_];
    sources::attachImu(scan, sequence_.imu(), next_ > 0 ? std::optional<double>(times_[next_ - 1]) : std::nullopt);
    ++next_;
    return scan;
  }
  std::optional<std::size_t> size() const override { return sequence_.size(); }
  const ClassTable& classTable() const override { return sequence_.classTable(); }
  std::string describe() const override { return sequence_.directory().string(); }
  bool canReread() const override { return true; }
  LabeledCloud reread(std::size_t index) const override { return sequence_.frame(index); }

 private:
  Sequence sequence_;
  std::vector<double> times_;
  bool read_channels_ = true;
  std::size_t next_ = 0;
};

}  // namespace

std::unique_ptr<ScanSource> sequenceScanSource(Sequence sequence, bool read_channels) {
  return std::make_unique<SequenceSource>(std::move(sequence), read_channels);
}

}  // namespace hazmap
