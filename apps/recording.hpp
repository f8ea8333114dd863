#pragma once
// What `hazmap info` and `hazmap convert` do with a recording (a bag or a packet capture) rather
// than a cloud file or a sequence folder.
#include <filesystem>
#include <string>

#include "source_flags.hpp"

namespace hazmap::cli {

/// True when `path` is a bag (.bag, .mcap, rosbag2 folder) or a packet capture.
bool isRecording(const std::filesystem::path& path);

/// `hazmap info` of a recording: its topics (type, count), duration, and for its LiDAR the scans
/// with their point counts (`frames`, `frame_list[i].points`).
void infoRecording(const std::filesystem::path& path, const SourceFlags& flags, bool json);

/// `hazmap convert` of a recording: a sequence folder (velodyne/NNNNNN.pcd with per-point times,
/// times.txt, odometry.txt and poses.txt when the recording has them, hazmap.yaml), written into
/// a temporary sibling folder renamed into place at the end (nothing partial on an error).
void convertRecording(const std::filesystem::path& input, const std::filesystem::path& out_dir,
                      const SourceFlags& flags, bool quiet);

}  // namespace hazmap::cli
