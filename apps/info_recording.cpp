// hazmap info BAG_OR_CAPTURE [--json]: topics (or UDP ports), duration, and the LiDAR's scans.
#include <fmt/format.h>

#include <iostream>
#include <map>
#include <nlohmann/json.hpp>

#include "hazmap/core/error.hpp"
#include "hazmap/sources/bag_message.hpp"
#include "hazmap/sources/pcap_reader.hpp"
#include "recording.hpp"

namespace hazmap::cli {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

/// Topics with their message counts (counted by reading when the container does not say) and
/// the log-time span.
json bagTopics(const fs::path& path, double& duration) {
  const auto reader = openBag(path);
  std::map<std::string, std::uint64_t> counted;
  bool need_count = false;
  for (const auto& t : reader->topics()) need_count = need_count || t.message_count == 0;
  auto [begin, end] = reader->timeRange();
  if (need_count || (begin == 0 && end == 0)) {
    BagMessage m;
    std::int64_t first = 0, last = 0;
    for (std::size_t k = 0; reader->next(m); ++k) {
      ++counted[m.topic->name];
      first = k == 0 ? m.log_time_ns : std::min(first, m.log_time_ns);
      last = std::max(last, m.log_time_ns);
    }
    if (begin == 0 && end == 0) begin = first, end = last;
  }
  duration = static_cast<double>(end - begin) * 1e-9;
  json topics = json::array();
  for (const auto& t : reader->topics())
    topics.push_back({{"name", t.name}, {"type", t.type},
                      {"count", need_count ? counted[t.name] : t.message_count},
                      {"serialization", t.serialization == Serialization::Cdr    ? "cdr"
                                        : t.serialization == Serialization::Ros1 ? "ros1"
                                                                                 : "other"}});
  return topics;
}

/// A capture's datagrams grouped by destination port and size.
json captureStreams(const fs::path& path, double& duration) {
  PcapReader reader(path);
  std::map<std::pair<std::uint16_t, std::size_t>, std::uint64_t> streams;
  UdpPacket p;
  double first = 0, last = 0;
  for (std::size_t k = 0; reader.next(p); ++k) {
    ++streams[{p.destination_port, p.payload.size()}];
    if (k == 0) first = p.time;
    last = p.time;
  }
  duration = last - first;
  json out = json::array();
  for (const auto& [key, count] : streams)
    out.push_back({{"port", key.first}, {"payload_bytes", key.second}, {"count", count}});
  return out;
}

}  // namespace

bool isRecording(const fs::path& path) { return isBag(path) || isPcap(path); }

void infoRecording(const fs::path& path, const SourceFlags& flags, bool as_json) {
  const bool bag = isBag(path);
  double duration = 0.0;
  json j = {{"path", path.string()}, {"kind", bag ? "bag" : "capture"}};
  j[bag ? "topics" : "udp_streams"] = bag ? bagTopics(path, duration) : captureStreams(path, duration);
  j["duration_s"] = duration;
  std::vector<std::string> notices;
  ScanSourceOptions options = flags.options();
  options.notice = [&](const std::string& line) { notices.push_back(line); };
  json frames = json::array();
  std::size_t points = 0;
  try {
    const auto scans = openScanSource(path, options);
    for (std::optional<Scan> scan; (scan = scans->next());) {
      frames.push_back({{"stamp", scan->stamp}, {"points", scan->cloud.size()},
                        {"odometry", scan->odometry.has_value()}});
      points += scan->cloud.size();
    }
    j["lidar"] = scans->describe();
  } catch (const Error& e) {
    // No LiDAR in the recording (or not decodable): the topics are still worth showing.
    j["lidar_error"] = e.what();
  }
  j["frames"] = frames.size();
  j["frame_list"] = frames;
  j["points"] = points;
  j["notices"] = notices;
  if (as_json) {
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << fmt::format("{}: {}, {:.3f} s\n", bag ? "bag" : "capture", path.string(), duration);
  for (const auto& t : j[bag ? "topics" : "udp_streams"])
    std::cout << (bag ? fmt::format("  {:<32} {:<36} {:>8} messages\n", t["name"].get<std::string>(),
                                    t["type"].get<std::string>(), t["count"].get<std::uint64_t>())
                      : fmt::format("  port {:>5}  {:>6} bytes  {:>8} datagrams\n", t["port"].get<int>(),
                                    t["payload_bytes"].get<std::size_t>(), t["count"].get<std::uint64_t>()));
  if (j.contains("lidar_error")) {
    std::cout << "LiDAR: " << j["lidar_error"].get<std::string>() << "\n";
    return;
  }
  std::cout << fmt::format("LiDAR: {}: {} scans, {} points", j["lidar"].get<std::string>(), frames.size(), points);
  if (!frames.empty()) std::cout << fmt::format(" ({} per scan on average)", points / frames.size());
  std::cout << "\n";
  for (std::size_t i = 0; i < frames.size(); ++i)
    std::cout << fmt::format("  scan {:>4}  t = {:.6f} s  {:>7} points\n", i, frames[i]["stamp"].get<double>(),
                             frames[i]["points"].get<std::size_t>());
  for (const auto& line : notices) std::cout << "notice: " << line << "\n";
}

}  // namespace hazmap::cli
