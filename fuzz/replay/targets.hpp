#pragma once
// The fuzz targets the replay runs in the normal build (fuzz/replay.cmake reads this list:
// each fuzz/fuzz_<name>.cpp is compiled with its LLVMFuzzerTestOneInput renamed to
// hazmapFuzz_<name>). fuzz_properties and fuzz_sim_cameras have no seed corpus yet: libFuzzer
// only (`make fuzz`); fuzz_label_spool (live cameras) is replayed here only (its sources are not
// in the libFuzzer build's subsets yet).
#include <cstddef>
#include <cstdint>

#define HAZMAP_FUZZ_REPLAY_TARGETS(X) \
  X(pcd) X(ply) X(kitti) X(trajectory) X(class_table) X(velodyne) X(hesai) X(pcap) X(ouster) X(imu) \
  X(mcap) X(ros1_bag) X(rosbag2) X(ros_messages) X(hazards_json) X(config) X(label_spool) \
  X(mission_json)

#define HAZMAP_FUZZ_DECLARE(name) extern "C" int hazmapFuzz_##name(const std::uint8_t*, std::size_t);
HAZMAP_FUZZ_REPLAY_TARGETS(HAZMAP_FUZZ_DECLARE)
#undef HAZMAP_FUZZ_DECLARE
