#pragma once
// Live scans with camera labels (issue 33, part 2). The live pass labels each scan from the
// cameras as it arrives and writes the labels to a spool (DIR/live_labels.bin) beside the
// LiDAR's (DIR/live.pcap); the run folder's second pass re-reads the LiDAR spool and takes each
// scan's labels back from the label spool, so the map and hazards hold exactly the labels
// tracking saw (the frames themselves are gone by then). The scans carry what a labelled
// sequence's do in `hazmap run --camera`: the rules' classes, the first channel as the point
// property, every channel named (second pass), and the camera class table (cameraClassTable).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/properties/live_camera.hpp"
#include "hazmap/sources/scan_source.hpp"

namespace hazmap {

/// A ScanSource whose scans get the live cameras' labels; each scan's labels are spooled.
class LiveLabelledScans final : public ScanSource {
 public:
  /// `scans` must outlive this. `spool` empty: labels are not kept.
  LiveLabelledScans(ScanSource& scans, LiveLabeler& labeler, const std::filesystem::path& spool);
  ~LiveLabelledScans() override;
  std::optional<Scan> next() override;
  std::optional<std::size_t> size() const override { return scans_.size(); }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override;
  /// Writes what the spool holds to disk (before its second pass reads it).
  void flush();
  /// The newest scan's named channels (one value per point), as the second pass gives them.
  const std::vector<PointChannel>& lastChannels() const { return last_channels_; }

 private:
  ScanSource& scans_;
  LiveLabeler& labeler_;
  ClassTable table_;
  std::FILE* spool_ = nullptr;
  std::filesystem::path spool_path_;
  std::vector<PointChannel> last_channels_;
};

/// `scans` (the LiDAR spool's, in the live pass's order) with the labels the label spool holds
/// for them; a scan the spool has no labels for (received after the last labelled one) stays
/// unlabelled. `channels` (the named channels) only when `read_channels`. Throws hazmap::Error
/// naming the spool for one that is corrupt or whose point counts disagree with the scans'.
std::unique_ptr<ScanSource> relabelFromSpool(std::unique_ptr<ScanSource> scans, const std::filesystem::path& spool,
                                             bool read_channels = true);

}  // namespace hazmap
