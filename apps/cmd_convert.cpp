// hazmap convert IN OUT: between .bin(+.label), .pcd and .ply, keeping classes and intensity; or a
// recording (bag, capture) into a sequence folder (recording.hpp).
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "command.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/pcd.hpp"
#include "hazmap/io/ply.hpp"
#include "recording.hpp"

namespace hazmap::cli {
namespace {

namespace fs = std::filesystem;

struct ConvertOptions {
  std::string input, output;
  std::string classes = "default";
  std::string label;
  std::string pcd_encoding = "binary";
  bool ply_ascii = false;
  bool quiet = false;
  SourceFlags source;
};

std::string lowerExt(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

bool isCloudFile(const fs::path& p) {
  const std::string ext = lowerExt(p);
  return ext == ".bin" || ext == ".pcd" || ext == ".ply";
}

void run(const ConvertOptions& o) {
  if (!isCloudFile(o.input)) {
    convertRecording(o.input, o.output, o.source, o.quiet);
    return;
  }
  const ClassTable table = ClassTable::load(o.classes);
  ReadStats st;
  std::optional<fs::path> label;
  if (!o.label.empty()) label = o.label;
  const LabeledCloud cloud = readCloud(o.input, table, &st, label);
  const std::string ext = lowerExt(o.output);
  if (ext == ".pcd") {
    PcdEncoding enc = PcdEncoding::Binary;
    if (o.pcd_encoding == "ascii") enc = PcdEncoding::Ascii;
    else if (o.pcd_encoding == "binary_compressed") enc = PcdEncoding::BinaryCompressed;
    writePcd(o.output, cloud, enc);
  } else if (ext == ".ply" && o.ply_ascii) {
    PlyWriteOptions opt;
    opt.binary = false;
    for (ClassId c : cloud.classes) {
      const ClassInfo* info = table.find(c);
      opt.colors.push_back(info ? info->color : Rgb{160, 160, 160});
    }
    writePly(o.output, cloud, opt);
  } else {
    writeCloud(o.output, cloud, table);
  }
  std::cout << fmt::format("{} ({}, {} points, {} non-finite dropped) -> {} ({} points)\n", o.input, st.format,
                           st.points_in_file, st.dropped_non_finite, o.output, cloud.size());
}

const RegisterCommand kRegister{
    {"convert",
     "Convert a cloud between .bin(+.label), .pcd and .ply, keeping classes and intensity; or a bag or "
     "capture into a sequence folder (velodyne/NNNNNN.pcd, times.txt, odometry.txt, imu.txt)",
     [](CLI::App& app) {
       auto o = std::make_shared<ConvertOptions>();
       app.add_option("input", o->input,
                      "Input cloud (.bin [+ .label beside it or in ../labels/], .pcd, .ply), or a bag (.bag, "
                      ".mcap, rosbag2 folder) or capture (.pcap)")
           ->required();
       app.add_option("output", o->output,
                      "Output cloud (.bin writes a .label beside it when any point has a class); for a "
                      "recording, the sequence folder to create")
           ->required();
       app.add_option("--classes", o->classes,
                      "Class table mapping the input's raw labels to classes: 'default', 'semantic-kitti' or "
                      "a YAML file");
       app.add_option("--label", o->label, "Label file for a .bin input (default: found automatically)");
       app.add_option("--pcd-encoding", o->pcd_encoding, "PCD output encoding")
           ->check(CLI::IsMember({"ascii", "binary", "binary_compressed"}));
       app.add_flag("--ply-ascii", o->ply_ascii, "Write PLY as ascii instead of binary_little_endian");
       app.add_flag("--quiet", o->quiet, "No notices and no summary");
       o->source.add(app, /*with_deskew=*/false);
       app.callback([o] { run(*o); });
     }}};

}  // namespace
}  // namespace hazmap::cli
