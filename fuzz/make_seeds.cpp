// Builds the fuzz seed corpus from the real shared data: small slices of the real KITTI scan
// (with its SemanticKITTI labels) and of the real PCD scan written in every format hazmap
// reads, the first poses of the real KITTI 00 ground truth as KITTI and TUM, the shipped class
// tables. Usage: hazmap_fuzz_seeds SHARED_DATA_DIR SOURCE_DIR OUT_DIR
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>

#include "hazmap/core/config_fields.hpp"
#include "hazmap/core/property_icp_config.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/io/kitti.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"
#include "hazmap/io/trajectory.hpp"

namespace fs = std::filesystem;
using namespace hazmap;

namespace {

/// Velodyne seeds in fuzz_velodyne's framing: the real VLP-16 capture's first UDP payloads
/// (classic pcap, Ethernet + IPv4 + UDP = 42 header bytes), as detected and as a forced model,
/// and a calibration YAML.
void velodyneSeeds(const fs::path& pcap, const fs::path& out) {
  fs::create_directories(out);
  const std::string file = readTextFile(pcap);
  std::string packets;
  int n = 0;
  for (std::size_t at = 24; at + 16 <= file.size() && n < 12; ++n) {
    std::uint32_t caplen;
    std::memcpy(&caplen, file.data() + at + 8, 4);
    const std::string frame = file.substr(at + 16, caplen);
    at += 16 + caplen;
    if (frame.size() < 42) continue;
    const std::string payload = frame.substr(42);
    packets += std::string(1, payload.size() == 1206 ? '\x00' : '\x01') + payload;
  }
  writeTextAtomically(out / "vlp16_detected", std::string("\x00\x00\x00", 3) + packets);
  writeTextAtomically(out / "vlp16_forced_cut90", std::string("\x01\x3c\x00", 3) + packets);
  writeTextAtomically(out / "vlp16_exact_fov", std::string("\x18\x00\x78", 3) + packets);
  std::string yaml = "\x80num_lasers: 16\ndistance_resolution: 0.002\nlasers:\n";
  for (int i = 0; i < 16; ++i)
    yaml += "  - {laser_id: " + std::to_string(i) + ", rot_correction: 0.0, vert_correction: " +
            std::to_string((i % 2 ? 1 : -1) * 0.01 * i) + ", dist_correction: 0.01}\n";
  writeTextAtomically(out / "calibration.yaml", yaml);
}

}  // namespace

/// A label spool as `hazmap live --camera` writes it (live_labels.cpp): one channel, scans 0 and 1
/// of three points each (classes, temperatures with one unobserved point).
void writeLabelSpoolSeed(const fs::path& path) {
  std::string bytes = "HZLABELS1\n";
  const auto put = [&](const auto& v) { bytes.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(std::uint32_t{1});
  put(std::uint32_t{11});
  bytes += "temperature";
  for (std::uint64_t scan = 0; scan < 2; ++scan) {
    put(scan);
    put(std::uint64_t{3});
    for (std::uint16_t c : {0, 1, 1}) put(c);
    for (float t : {20.5f, 75.0f, std::numeric_limits<float>::quiet_NaN()}) put(t);
  }
  writeTextAtomically(path, bytes);
}

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: hazmap_fuzz_seeds SHARED_DATA_DIR SOURCE_DIR OUT_DIR\n";
    return 2;
  }
  const fs::path data = argv[1], source = argv[2], out = argv[3];
  try {
    for (const char* d : {"pcd", "ply", "kitti", "trajectory", "class_table", "hazards_json", "config", "label_spool",
                          "mission_json"})
      fs::create_directories(out / d);
    const auto scan = readKittiScan(data / "kitti-semantic-sample/velodyne/000000.bin",
                                    data / "kitti-semantic-sample/labels/000000.label", ClassTable::defaults());
    const auto pair = readPcd(data / "scan-pair/251370668.pcd");
    // Slices from the middle of the scans, where points carry classes.
    const LabeledCloud small = scan.slice(60000, 60064);
    LabeledCloud timed = pair.slice(1000, 1048);
    timed.enableTimestamps();
    timed.enableProperty();
    for (std::size_t i = 0; i < timed.size(); ++i) timed.timestamps[i] = 0.001 * double(i), timed.property[i] = 20.0f + i;

    writePcd(out / "pcd/ascii.pcd", small, PcdEncoding::Ascii);
    writePcd(out / "pcd/binary.pcd", small, PcdEncoding::Binary);
    writePcd(out / "pcd/compressed.pcd", small, PcdEncoding::BinaryCompressed);
    writePcd(out / "pcd/timed_compressed.pcd", timed, PcdEncoding::BinaryCompressed);
    writePcd(out / "pcd/timed_ascii.pcd", timed, PcdEncoding::Ascii);
    {  // the real file's own header with the first 32 points
      const std::string real = readTextFile(data / "scan-pair/251370668.pcd");
      std::string head = real.substr(0, real.find("DATA binary\n") + 12);
      for (const char* key : {"WIDTH 69088", "POINTS 69088"}) {
        const auto at = head.find(key);
        if (at != std::string::npos) head.replace(at, std::string(key).size(), std::string(key).substr(0, std::string(key).size() - 5) + "32");
      }
      writeTextAtomically(out / "pcd/real_header.pcd", head + real.substr(real.find("DATA binary\n") + 12, 32 * 16));
    }

    PlyWriteOptions opt;
    opt.binary = false;
    writePly(out / "ply/ascii.ply", small, opt);
    opt.binary = true;
    writePly(out / "ply/binary.ply", timed, opt);
    TriangleMesh mesh;
    for (int i = 0; i < 6; ++i) mesh.vertices.push_back(small.points[i]);
    mesh.triangles = {{0, 1, 2}, {2, 3, 4}, {3, 4, 5}};
    mesh.triangle_classes = {0, 1, 3};
    mesh.vertex_colors.assign(6, Rgb{10, 20, 30});
    writePlyMesh(out / "ply/mesh_ascii.ply", mesh, false);
    writePlyMesh(out / "ply/mesh_binary.ply", mesh, true);

    // KITTI pair in the fuzz target's framing: mode byte 1, then .bin, then .label.
    const auto pieceBin = out / "kitti/tmp.bin";
    const auto pieceLabel = out / "kitti/tmp.label";
    const LabeledCloud tiny = scan.slice(62000, 62032);
    writeKittiBin(pieceBin, tiny);
    writeSemanticKittiLabels(pieceLabel, tiny);
    const std::string b = readTextFile(pieceBin), l = readTextFile(pieceLabel);
    writeTextAtomically(out / "kitti/pair", std::string(1, '\x01') + b + l);
    writeTextAtomically(out / "kitti/bin", std::string(1, '\x00') + b);
    writeTextAtomically(out / "kitti/label", std::string(1, '\x02') + l);
    fs::remove(pieceBin);
    fs::remove(pieceLabel);

    Trajectory gt = readKittiTrajectory(data / "trajectories/KITTI_00_gt.txt");
    gt.poses.resize(8);
    gt.stamps.resize(8);
    writeKittiTrajectory(out / "trajectory/kitti.txt", gt);
    writeTumTrajectory(out / "trajectory/tum.txt", gt);
    {
      const std::string real = readTextFile(data / "trajectories/KITTI_00_gt.txt");
      std::size_t at = 0;
      for (int k = 0; k < 5; ++k) at = real.find('\n', at) + 1;
      writeTextAtomically(out / "trajectory/real.txt", real.substr(0, at));
    }
    fs::copy_file(data / "scan-pair/relative.txt", out / "trajectory/relative.txt",
                  fs::copy_options::overwrite_existing);  // a transform file

    velodyneSeeds(data / "sensors/velodyne-vlp16-pcap/velodyne_vlp16.pcap", out / "velodyne");

    for (const auto& e : fs::directory_iterator(source / "config/classes"))
      fs::copy_file(e.path(), out / "class_table" / e.path().filename(), fs::copy_options::overwrite_existing);
    // fuzz_config: the property_icp section as the config mechanism writes it, bare and under
    // its section key, with the class-radius map filled.
    PropertyIcpConfig icp;
    icp.mismatch_penalty = 0.5;
    icp.class_radius = {{"wall", 0.3}, {"hot", 1.2}};
    writeTextAtomically(out / "config/defaults.yaml", configToYaml(PropertyIcpConfig{}));
    writeTextAtomically(out / "config/section.yaml", configToYaml(icp, "property_icp"));
    // changes.json of a merge and graph_extras.json of a map folder (issue 34).
    writeTextAtomically(out / "mission_json/changes.json", R"({"changes": [
 {"kinds": ["moved"], "class": "heat", "before_id": 2, "after_id": 1, "before": [0.33, 13.01, 0.09],
  "after": [0.35, 15.08, 0.08], "moved_m": 2.06, "area_before_m2": 0.86, "area_after_m2": 0.81,
  "value_before": null, "value_after": 61.5, "frames_before": [[0, 4], [29, 32]], "frames_after": [[0, 23]],
  "confidence": 1.0, "mission": 2},
 {"kinds": ["gone"], "class": "heat", "before_id": 1, "after_id": 0, "before": [12.6, 1.39, 0.18], "after": null,
  "moved_m": 0.0, "area_before_m2": 0.41, "area_after_m2": 0.0, "value_before": null, "value_after": null,
  "frames_before": [[0, 35]], "frames_after": [], "confidence": 1.0}], "counts": {"gone": 1, "moved": 1}}
)");
    writeTextAtomically(out / "mission_json/graph_extras.json",
                        R"({"edges": 2, "loop_edges": [1], "map_anchor_edges": [], "gravity_world": [0, 0, -1],)"
                        R"( "gravity_priors": [{"node": 0, "down": [0, 0, -1], "sigma": 0.01}, {"node": 2, "down": [0.01, 0, -0.99995], "sigma": 0.02}]})"
                        "\n");
    // map.json as `hazmap run` writes it (two keyframes, one landmark, the search overview).
    writeTextAtomically(out / "mission_json/map.json", R"({
 "format": "hazmap-map/1", "method": "property-icp+pgo", "source": "naraha", "frames": 30,
 "classes": "classes.yaml", "sensor_height_m": 0.5, "graph": "graph.g2o", "graph_extras": "graph_extras.json",
 "hazards": "hazards.json", "trajectory": "trajectory.kitti",
 "parameters": {"slam": {"keyframe_distance": 0.9}},
 "keyframes": [
  {"frame": 0, "stamp": 0.0, "pose": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0], "cloud": "keyframes/000000.pcd",
   "points": 28000, "landmarks": []},
  {"frame": 4, "stamp": 0.4, "pose": [1, 0, 0, 1.2, 0, 1, 0, 0, 0, 0, 1, 0], "cloud": "keyframes/000004.pcd",
   "points": 28100, "landmarks": [{"axes": [0.97, -0.25, 0.03, -0.01, 0.11, 0.99, -0.25, -0.96, 0.10],
   "box_max": [13.13, 1.50, 0.69], "box_min": [11.98, 1.37, -0.23], "centroid": [12.40, 1.42, 0.30], "class": 1,
   "extent": [0.42, 0.32, 0.04], "points": 15, "purity": 0.88, "mean_property": 61.5}]}],
 "search_overview": {"cloud": "search_overview.pcd", "voxel": 0.25, "property_classes": [1, 2, 3]},
 "files": [
  {"path": "graph.g2o", "bytes": 1200, "fnv1a": "00000000000004d2"},
  {"path": "trajectory.kitti", "bytes": 300, "fnv1a": "0123456789abcdef"},
  {"path": "hazards.json", "bytes": 90, "fnv1a": "fedcba9876543210"},
  {"path": "classes.yaml", "bytes": 400, "fnv1a": "0000000000000001"},
  {"path": "graph_extras.json", "bytes": 120, "fnv1a": "0000000000000002"},
  {"path": "keyframes/000000.pcd", "bytes": 390000, "fnv1a": "0000000000000003"},
  {"path": "keyframes/000004.pcd", "bytes": 391000, "fnv1a": "0000000000000004"},
  {"path": "search_overview.pcd", "bytes": 816563, "fnv1a": "0000000000000005"}]}
)");
    // hazards.json as `hazmap run` writes it (two hazards of the demo's map).
    writeTextAtomically(out / "hazards_json/hazards.json", R"({"count": 2, "voxel_size": 0.1, "hazards": [
 {"id": 1, "class": "heat", "class_id": 1, "kind": "heat", "centroid": [12.59, 1.39, 0.21],
  "min": [11.9, 1.2, -0.4], "max": [13.3, 1.6, 0.8], "extent": [1.4, 0.4, 1.2], "area_m2": 0.49,
  "cells": 97, "points": 1203, "mean_property": null, "frame_count": 31, "frames": [[0, 12], [140, 162]]},
 {"id": 2, "class": "water", "class_id": 2, "kind": "water", "centroid": [17.5, -0.2, -0.4],
  "min": [16.4, -1.0, -0.5], "max": [18.5, 0.6, -0.3], "extent": [2.1, 1.6, 0.2], "area_m2": 2.48,
  "cells": 250, "points": 4100, "mean_property": 1.0, "frame_count": 20, "frames": [[20, 39]]}]}
)");
    writeLabelSpoolSeed(out / "label_spool/live_labels.bin");
  } catch (const std::exception& e) {
    std::cerr << "hazmap_fuzz_seeds: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
