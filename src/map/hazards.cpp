#include "hazmap/map/hazards.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <unordered_map>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace {

struct IndexHash {
  std::size_t operator()(const Eigen::Vector3i& v) const {
    return std::size_t(v.x()) * 73856093u ^ std::size_t(v.y()) * 19349663u ^ std::size_t(v.z()) * 83492791u;
  }
};

// RFC 4180 quoting for a text field.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// Each channel over a region's cells: sample-weighted mean, max.
std::vector<HazardChannel> channelsOf(const std::vector<MapCell>& all, const std::vector<std::size_t>& members,
                                      const std::vector<std::string>& names) {
  std::vector<HazardChannel> out;
  for (std::size_t k = 0; k < names.size(); ++k) {
    HazardChannel h{names[k], std::nullopt, std::nullopt, 0};
    double sum = 0, max = -std::numeric_limits<double>::infinity();
    for (std::size_t m : members) {
      if (k >= all[m].channels.size() || all[m].channels[k].samples == 0) continue;
      const ChannelStats& s = all[m].channels[k];
      sum += double(s.mean) * s.samples;
      h.samples += s.samples;
      max = std::max(max, double(s.max));
    }
    if (h.samples) {
      h.mean = sum / double(h.samples);
      h.max = max;
    }
    out.push_back(std::move(h));
  }
  return out;
}

}  // namespace

std::vector<Hazard> findHazards(const GlobalMap& map, const HazardConfig& config) {
  config.validate();
  const ClassTable& table = map.classTable();
  const double v = map.voxelSize();
  const std::vector<MapCell> all = map.cells();

  // Property cells per class, looked up by index.
  std::map<ClassId, std::unordered_map<Eigen::Vector3i, std::size_t, IndexHash>> by_class;
  for (std::size_t i = 0; i < all.size(); ++i)
    if (table.isProperty(all[i].label)) by_class[all[i].label].emplace(all[i].index, i);

  std::vector<Hazard> out;
  const int L = config.link_cells;
  std::vector<bool> visited(all.size(), false);  // by index into `all`
  for (const auto& [label, lookup] : by_class) {
    // Seeds in sorted cell order (all is sorted) → deterministic components.
    std::vector<std::size_t> seeds;
    for (const auto& [idx, i] : lookup) seeds.push_back(i);
    std::sort(seeds.begin(), seeds.end());
    std::vector<Hazard> regions;
    for (std::size_t seed : seeds) {
      if (visited[seed]) continue;
      std::vector<std::size_t> members, stack{seed};
      visited[seed] = true;
      while (!stack.empty()) {
        const std::size_t cur = stack.back();
        stack.pop_back();
        members.push_back(cur);
        const Eigen::Vector3i c = all[cur].index;
        for (int dz = -L; dz <= L; ++dz)
          for (int dy = -L; dy <= L; ++dy)
            for (int dx = -L; dx <= L; ++dx) {
              auto it = lookup.find(c + Eigen::Vector3i(dx, dy, dz));
              if (it == lookup.end() || visited[it->second]) continue;
              visited[it->second] = true;
              stack.push_back(it->second);
            }
      }
      Hazard h;
      h.label = label;
      const ClassInfo* info = table.find(label);
      h.class_name = info ? info->name : std::to_string(label);
      h.kind = info ? info->kind : PropertyKind::Other;
      h.min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      h.max = -h.min;
      std::set<std::pair<int, int>> footprint;
      double prop_sum = 0, prop_max = -std::numeric_limits<double>::infinity();
      std::size_t prop_n = 0;
      std::vector<FrameRange> frames;
      for (std::size_t m : members) {
        const MapCell& cell = all[m];
        h.points += cell.points;
        h.centroid += cell.centroid.cast<double>() * double(cell.points);
        const Eigen::Vector3d lo = cell.index.cast<double>() * v;
        h.min = h.min.cwiseMin(lo);
        h.max = h.max.cwiseMax(lo + Eigen::Vector3d::Constant(v));
        footprint.emplace(cell.index.x(), cell.index.y());
        prop_sum += double(cell.property_mean) * cell.property_samples;
        prop_n += cell.property_samples;
        if (cell.property_samples) prop_max = std::max(prop_max, double(cell.property_max));
        frames.insert(frames.end(), cell.frames.begin(), cell.frames.end());
      }
      h.cells = members.size();
      if (h.cells < config.min_cells || h.points < config.min_points) continue;
      h.centroid /= double(h.points);
      h.area_m2 = double(footprint.size()) * v * v;
      if (prop_n) h.mean_property = prop_sum / double(prop_n);
      if (prop_n) h.max_property = prop_max;
      h.frames = unionRanges(std::move(frames));
      h.frame_count = countFrames(h.frames);  // exact unless a cell's list was capped
      h.channels = channelsOf(all, members, map.channelNames());
      regions.push_back(std::move(h));
    }
    std::stable_sort(regions.begin(), regions.end(),
                     [](const Hazard& a, const Hazard& b) { return a.points > b.points; });
    for (auto& r : regions) out.push_back(std::move(r));
  }
  for (std::size_t i = 0; i < out.size(); ++i) out[i].id = int(i) + 1;
  return out;
}

std::string hazardsJson(const std::vector<Hazard>& hazards, double voxel_size, int indent,
                        const std::vector<HazardChannelInfo>& channel_info) {
  const auto vec = [](const Eigen::Vector3d& p) { return nlohmann::json::array({p.x(), p.y(), p.z()}); };
  nlohmann::json list = nlohmann::json::array();
  for (const auto& h : hazards) {
    nlohmann::json frames = nlohmann::json::array();
    for (const auto& r : h.frames) frames.push_back({r.first, r.last});
    nlohmann::json channels = nlohmann::json::object();
    const auto orNull = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
    for (const auto& c : h.channels)
      channels[c.name] = {{"mean", orNull(c.mean)}, {"max", orNull(c.max)}, {"samples", c.samples}};
    list.push_back({{"id", h.id},
                    {"class", h.class_name},
                    {"class_id", h.label},
                    {"kind", toString(h.kind)},
                    {"centroid", vec(h.centroid)},
                    {"min", vec(h.min)},
                    {"max", vec(h.max)},
                    {"extent", vec(h.extent())},
                    {"area_m2", h.area_m2},
                    {"cells", h.cells},
                    {"points", h.points},
                    {"mean_property", h.mean_property ? nlohmann::json(*h.mean_property) : nlohmann::json()},
                    {"max_property", h.max_property ? nlohmann::json(*h.max_property) : nlohmann::json()},
                    {"frame_count", h.frame_count},
                    {"frames", frames},
                    {"channels", channels}});
  }
  nlohmann::json j{{"voxel_size", voxel_size}, {"count", hazards.size()}, {"hazards", list}};
  if (!channel_info.empty()) {
    nlohmann::json channels = nlohmann::json::array();
    for (const auto& c : channel_info) channels.push_back({{"name", c.name}, {"cameras", c.cameras}});
    j["channels"] = channels;
  }
  return j.dump(indent);
}

void writeHazardsJson(const std::filesystem::path& path, const std::vector<Hazard>& hazards,
                      double voxel_size, const std::vector<HazardChannelInfo>& channels) {
  writeTextAtomically(path, hazardsJson(hazards, voxel_size, 2, channels) + "\n");
}

void writeHazardsCsv(const std::filesystem::path& path, const std::vector<Hazard>& hazards) {
  std::ostringstream s;
  s << std::setprecision(10);
  s << "id,class,kind,centroid_x,centroid_y,centroid_z,extent_x,extent_y,extent_z,min_x,min_y,"
       "min_z,max_x,max_y,max_z,area_m2,cells,points,mean_property,frame_count,frames,max_property";
  // Every hazard of one map has the map's channels; the first hazard names them.
  const std::vector<HazardChannel> none;
  const std::vector<HazardChannel>& names = hazards.empty() ? none : hazards.front().channels;
  for (const auto& c : names) s << ',' << csvField(c.name + "_mean") << ',' << csvField(c.name + "_max");
  s << '\n';
  for (const auto& h : hazards) {
    s << h.id << ',' << csvField(h.class_name) << ',' << toString(h.kind);
    s << ',' << h.centroid.x() << ',' << h.centroid.y() << ',' << h.centroid.z();
    const Eigen::Vector3d e = h.extent();
    s << ',' << e.x() << ',' << e.y() << ',' << e.z();
    s << ',' << h.min.x() << ',' << h.min.y() << ',' << h.min.z();
    s << ',' << h.max.x() << ',' << h.max.y() << ',' << h.max.z();
    s << ',' << h.area_m2 << ',' << h.cells << ',' << h.points << ',';
    if (h.mean_property) s << *h.mean_property;
    s << ',' << h.frame_count << ',';
    for (std::size_t i = 0; i < h.frames.size(); ++i)
      s << (i ? ";" : "") << h.frames[i].first << '-' << h.frames[i].last;
    s << ',';
    if (h.max_property) s << *h.max_property;
    for (std::size_t k = 0; k < names.size(); ++k) {
      const HazardChannel* c = k < h.channels.size() ? &h.channels[k] : nullptr;
      s << ',';
      if (c && c->mean) s << *c->mean;
      s << ',';
      if (c && c->max) s << *c->max;
    }
    s << '\n';
  }
  writeTextAtomically(path, s.str());
}

}  // namespace hazmap

