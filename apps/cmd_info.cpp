// hazmap info PATH [--json]: what a cloud file, a sequence directory, a bag or a capture holds.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>

#include "command.hpp"
#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/io/cloud_file.hpp"
#include "hazmap/io/sequence.hpp"
#include "recording.hpp"

namespace hazmap::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct InfoOptions {
  std::string path;
  std::string classes;  // empty: default table (or the sequence's hazmap.yaml)
  bool json = false;
  SourceFlags source;
};

/// Running totals over one or more clouds.
struct Summary {
  std::size_t points = 0, points_in_file = 0, dropped = 0;
  AxisAlignedBox box;
  std::map<ClassId, std::size_t> histogram;
  void add(const LabeledCloud& c, const ReadStats& st) {
    points += c.size();
    points_in_file += st.points_in_file;
    dropped += st.dropped_non_finite;
    const AxisAlignedBox b = c.bounds();
    if (!b.empty()) box.extend(b.min), box.extend(b.max);
    for (ClassId k : c.classes) ++histogram[k];
  }
};

json boxJson(const AxisAlignedBox& box) {
  if (box.empty()) return nullptr;
  return {{"min", {box.min.x(), box.min.y(), box.min.z()}}, {"max", {box.max.x(), box.max.y(), box.max.z()}}};
}

json histogramJson(const Summary& s, const ClassTable& table) {
  json out = json::array();
  for (const auto& [id, n] : s.histogram) {
    const ClassInfo* info = table.find(id);
    out.push_back({{"id", id}, {"name", info ? info->name : "(not in class table)"},
                   {"kind", info ? toString(info->kind) : "unknown"}, {"points", n}});
  }
  return out;
}

void printSummary(const Summary& s, const ClassTable& table) {
  std::cout << fmt::format("points: {} (in file {}, dropped non-finite {})\n", s.points, s.points_in_file,
                           s.dropped);
  if (s.box.empty()) {
    std::cout << "bounds: (empty)\n";
  } else {
    std::cout << fmt::format("bounds: min [{:.3f}, {:.3f}, {:.3f}]  max [{:.3f}, {:.3f}, {:.3f}]\n", s.box.min.x(),
                             s.box.min.y(), s.box.min.z(), s.box.max.x(), s.box.max.y(), s.box.max.z());
  }
  std::cout << "classes:\n";
  for (const auto& [id, n] : s.histogram) {
    const ClassInfo* info = table.find(id);
    std::cout << fmt::format("  {:>5}  {:<20} {:>10}  ({:.2f}%)\n", id,
                             info ? info->name + " (" + toString(info->kind) + ")" : "(not in table)", n,
                             s.points ? 100.0 * double(n) / double(s.points) : 0.0);
  }
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : " ") + s;
  return out;
}

void infoCloud(const InfoOptions& o) {
  const ClassTable table = ClassTable::load(o.classes);
  ReadStats st;
  const LabeledCloud cloud = readCloud(o.path, table, &st);
  Summary s;
  s.add(cloud, st);
  if (o.json) {
    json j = {{"path", o.path}, {"kind", "cloud"}, {"format", st.format}, {"fields", st.fields},
              {"points", s.points}, {"points_in_file", s.points_in_file}, {"dropped_non_finite", s.dropped},
              {"bounds", boxJson(s.box)}, {"classes", histogramJson(s, table)}};
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << "file: " << o.path << "\nformat: " << st.format << "\nfields: " << join(st.fields) << "\n";
  printSummary(s, table);
}

void infoSequence(const InfoOptions& o) {
  std::optional<ClassTable> override_table;
  if (!o.classes.empty()) override_table = ClassTable::load(o.classes);
  const Sequence seq = Sequence::open(o.path, override_table);
  if (!seq.tableNote().empty()) std::cerr << "notice: " << seq.tableNote() << "\n";
  Summary total;
  json frames = json::array();
  std::map<std::string, std::size_t> formats;
  for (std::size_t i = 0; i < seq.size(); ++i) {
    ReadStats st;
    const LabeledCloud c = seq.frame(i, &st);
    total.add(c, st);
    ++formats[st.format];
    frames.push_back({{"file", seq.scanPath(i).filename().string()}, {"format", st.format}, {"fields", st.fields},
                      {"points", c.size()}, {"dropped_non_finite", st.dropped_non_finite}});
  }
  const auto trajectoryJson = [](const std::optional<Trajectory>& t) -> json {
    if (!t) return nullptr;
    return {{"poses", t->size()}};
  };
  if (o.json) {
    json j = {{"path", o.path}, {"kind", "sequence"}, {"frames", seq.size()}, {"frame_list", frames},
              {"points", total.points}, {"points_in_file", total.points_in_file},
              {"dropped_non_finite", total.dropped}, {"bounds", boxJson(total.box)},
              {"classes", histogramJson(total, seq.classTable())},
              {"ground_truth", trajectoryJson(seq.groundTruth())}, {"odometry", trajectoryJson(seq.odometry())},
              {"sensor", seq.sensorYaml()}};
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << "sequence: " << o.path << "\nframes: " << seq.size() << "\n";
  for (const auto& [f, n] : formats) std::cout << fmt::format("  {} frames: {}\n", f, n);
  std::cout << "ground truth (poses.txt): " << (seq.groundTruth() ? std::to_string(seq.groundTruth()->size()) + " poses" : "none")
            << "\nodometry (odometry.txt): " << (seq.odometry() ? std::to_string(seq.odometry()->size()) + " poses" : "none")
            << "\n";
  if (!seq.sensorYaml().empty()) {
    std::cout << "sensor:\n";
    std::string line;
    for (char ch : seq.sensorYaml()) {
      if (ch != '\n') { line += ch; continue; }
      if (!line.empty()) std::cout << "  " << line << "\n";
      line.clear();
    }
    if (!line.empty()) std::cout << "  " << line << "\n";
  }
  printSummary(total, seq.classTable());
}

const RegisterCommand kRegister{{"info",
                                 "Describe a cloud file (.bin/.pcd/.ply), a sequence directory, a bag "
                                 "(.bag, .mcap, rosbag2 folder) or a capture (.pcap)",
                                 [](CLI::App& app) {
                                   auto o = std::make_shared<InfoOptions>();
                                   app.add_option("path", o->path,
                                                  "Cloud file, sequence directory, bag or capture")
                                       ->required();
                                   app.add_flag("--json", o->json, "Print JSON instead of text");
                                   app.add_option("--classes", o->classes,
                                                  "Class table: 'default', 'semantic-kitti' or a YAML file "
                                                  "(for a sequence: overrides hazmap.yaml)");
                                   o->source.add(app, /*with_deskew=*/false);
                                   app.callback([o] {
                                     std::error_code ec;
                                     if (isRecording(o->path))
                                       infoRecording(o->path, o->source, o->json);
                                     else if (fs::is_directory(o->path, ec))
                                       infoSequence(*o);
                                     else
                                       infoCloud(*o);
                                   });
                                 }}};

}  // namespace
}  // namespace hazmap::cli
