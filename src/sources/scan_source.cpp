// openScanSource: what a path holds decides which ScanSource reads it.
#include "hazmap/sources/scan_source.hpp"

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/pcap_reader.hpp"

namespace hazmap::sources {
std::unique_ptr<ScanSource> openBagScanSource(const std::filesystem::path& path, const ScanSourceOptions& options);
std::unique_ptr<ScanSource> openPcapScanSource(const std::filesystem::path& path, const ScanSourceOptions& options);
}  // namespace hazmap::sources

namespace hazmap {

namespace fs = std::filesystem;

LabeledCloud ScanSource::reread(std::size_t index) const {
  fail(describe(), "scan " + std::to_string(index) + " cannot be read again (a stream, not a folder)");
}

std::unique_ptr<ScanSource> openScanSource(const fs::path& path, const ScanSourceOptions& options) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail(path.string(), "not found");
  if (fs::is_directory(path / "velodyne", ec)) {
    Sequence sequence = Sequence::open(path, options.class_table);
    if (options.notice && !sequence.tableNote().empty()) options.notice(sequence.tableNote());
    if (options.notice && !sequence.imuNote().empty()) options.notice(sequence.imuNote());
    return sequenceScanSource(std::move(sequence), options.read_channels);
  }
  if (isBag(path)) return sources::openBagScanSource(path, options);
  if (isPcap(path)) return sources::openPcapScanSource(path, options);
  fail(path.string(), "neither a sequence folder (velodyne/), a bag (.bag, .mcap, rosbag2 folder) nor a "
                      "packet capture (.pcap)");
}

}  // namespace hazmap
