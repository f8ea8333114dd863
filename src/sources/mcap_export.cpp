#include "hazmap/sources/mcap_export.hpp"

#include <cmath>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/mcap_writer.hpp"
#include "hazmap/sources/ros_encode.hpp"
#include "sources/topic_selection.hpp"

namespace hazmap {

namespace {

std::int64_t nanoseconds(double seconds) { return std::llround(seconds * 1e9); }

}  // namespace

McapExportSummary writeScansAsMcap(ScanSource& scans, const std::filesystem::path& path,
                                   const std::vector<McapExtraTopic>& extra) {
  McapWriter writer(path);
  std::vector<std::uint16_t> extra_channels;
  std::vector<std::size_t> extra_next(extra.size(), 0);
  for (const McapExtraTopic& e : extra) extra_channels.push_back(writer.addRosChannel(e.topic, e.type));
  const auto writeExtraUpTo = [&](double t) {
    for (std::size_t k = 0; k < extra.size(); ++k)
      for (std::size_t& i = extra_next[k]; i < extra[k].stamps.size() && extra[k].stamps[i] <= t; ++i)
        writer.write(extra_channels[k], nanoseconds(extra[k].stamps[i]), extra[k].message(i));
  };
  const auto points = writer.addRosChannel("/velodyne_points", sources::kPointCloud2Type);
  const auto odom = writer.addRosChannel("/odom", sources::kOdometryType);
  const auto truth = writer.addRosChannel(sources::kGroundTruthTopic, sources::kPoseStampedType);
  const auto table = writer.addRosChannel(sources::kClassTableTopic, sources::kStringType);
  McapExportSummary summary;
  for (std::optional<Scan> scan; (scan = scans.next());) {
    const std::int64_t t = nanoseconds(scan->stamp);
    if (!std::isfinite(scan->stamp) || scan->stamp < 0)
      fail(scans.describe(), "scan " + std::to_string(scan->index) + " has no valid time for a bag");
    if (summary.scans == 0) writer.write(table, t, encodeString(scans.classTable().toYamlString()));
    writeExtraUpTo(scan->stamp);
    writer.write(points, t, encodePointCloud2(cloudToPointCloud2(scan->cloud, {scan->stamp, "velodyne"})));
    if (scan->odometry) {
      OdometryMsg o;
      o.header = {scan->stamp, "odom"};
      o.child_frame_id = "velodyne";
      o.pose = *scan->odometry;
      writer.write(odom, t, encodeOdometry(o));
      ++summary.odometry;
    }
    if (scan->ground_truth) {
      writer.write(truth, t, encodePoseStamped({scan->stamp, "world"}, *scan->ground_truth));
      ++summary.ground_truth;
    }
    ++summary.scans;
  }
  if (summary.scans == 0) fail(scans.describe(), "has no scans to write");
  writeExtraUpTo(std::numeric_limits<double>::infinity());
  writer.close();
  return summary;
}

}  // namespace hazmap
