#include "hazmap/map/viewer.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "viewer_data.hpp"
#include "viewer_template.hpp"  // generated from src/map/viewer/ by cmake/embed_text.cmake

namespace hazmap {

namespace {

using nlohmann::json;

std::string css(const Rgb& c) { return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]); }

double mm(double v) { return std::round(v * 1000.0) / 1000.0; }
json xyz(const Eigen::Vector3d& p) { return json::array({mm(p.x()), mm(p.y()), mm(p.z())}); }

json hazardsMeta(const std::vector<Hazard>& hazards, const ClassTable& classes, const MapColorConfig& colors) {
  json list = json::array();
  for (const Hazard& h : hazards) {
    const ClassInfo* info = classes.find(h.label);
    ClassInfo by_kind;
    by_kind.kind = h.kind;
    const Rgb color = propertyColor(info && info->kind == h.kind ? *info : by_kind, colors);
    list.push_back({{"id", h.id}, {"class", h.class_name}, {"kind", toString(h.kind)},
                    {"centroid", xyz(h.centroid)}, {"min", xyz(h.min)}, {"max", xyz(h.max)},
                    {"area_m2", h.area_m2}, {"points", h.points}, {"frame_count", h.frame_count},
                    {"mean_property", h.mean_property ? json(*h.mean_property) : json()},
                    {"max_property", h.max_property ? json(*h.max_property) : json()},
                    {"color", css(color)}});
  }
  return list;
}

json metaJson(const ViewerScene& scene, const ViewerConfig& config, const viewer::EncodedPoints& e) {
  json groups = json::array();
  for (const auto& g : e.groups)
    groups.push_back({{"id", g.id}, {"name", g.name}, {"kind", g.kind}, {"css", css(g.color)},
                      {"offset", g.offset}, {"count", g.count}});
  json trajectories = json::array();
  for (const auto& t : scene.trajectories) {
    json points = json::array();
    for (const auto& p : t.positions)
      if (p.allFinite()) points.push_back(xyz(p));
    trajectories.push_back({{"name", t.name}, {"color", css(t.color)}, {"points", points}});
  }
  const auto vec = [](const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); };
  json meta = {{"title", scene.title}, {"source", scene.source}, {"groups", groups},
          {"points_total", e.total}, {"points_embedded", e.embedded}, {"has_property", e.has_property},
          {"qmin", vec(e.qmin)}, {"qstep", vec(e.qstep)}, {"center", vec(e.center)},
          {"hazards", hazardsMeta(scene.hazards, scene.classes, scene.colors)}, {"trajectories", trajectories},
          {"clip_above", scene.clip_above ? json(*scene.clip_above) : json()},
          {"detail_budget", config.detail_budget}, {"moving_budget", config.moving_budget},
          {"initial_view", config.top_down_first ? "top" : "perspective"}, {"live", config.live}};
  // Only a page with changes carries the key (every other page stays as it was).
  if (!scene.changes.empty()) {
    json changes = json::array();
    for (const auto& c : scene.changes) changes.push_back(json::parse(hazardChangeJson(c)));
    meta["changes"] = std::move(changes);
  }
  return meta;
}

// Text placed inside <script>: "</" could end the element early.
std::string scriptSafe(std::string text) {
  for (std::size_t at = 0; (at = text.find("</", at)) != std::string::npos; at += 3) text.replace(at, 2, "<\\/");
  return text;
}

std::string htmlEscape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

// Replaces each {{NAME}} of the template once, in one pass (inserted text is never rescanned).
std::string fillTemplate(std::string_view page, const std::vector<std::pair<std::string, std::string>>& values) {
  std::string out;
  std::size_t at = 0;
  while (true) {
    const std::size_t open = page.find("{{", at);
    if (open == std::string_view::npos) break;
    const std::size_t close = page.find("}}", open);
    if (close == std::string_view::npos) break;
    const std::string_view name = page.substr(open + 2, close - open - 2);
    out.append(page.substr(at, open - at));
    bool found = false;
    for (const auto& [key, value] : values)
      if (key == name) {
        out += value;
        found = true;
      }
    if (!found) fail("viewer template", "unknown placeholder {{" + std::string(name) + "}}");
    at = close + 2;
  }
  out.append(page.substr(at));
  return out;
}

std::string readThree(const std::filesystem::path& dir, const std::string& rel) {
  const auto path = dir / rel;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    fail(path.string(), "missing: install Debian's libjs-three (scripts/install-deps.sh)");
  return readTextFile(path);
}

std::string dataBlock(const std::string& id, const std::string& base64) {
  return "<script type=\"application/octet-stream\" id=\"" + id + "\">" + base64 + "</script>\n";
}

}  // namespace

std::string viewerHtml(const ViewerScene& scene, const ViewerConfig& config, ViewerReport* report) {
  const std::string three = readThree(config.three_dir, "three.min.js");
  const std::string orbit = readThree(config.three_dir, "examples/js/controls/OrbitControls.js");
  const std::size_t fixed = three.size() + orbit.size() + embedded::kViewerPage.size() +
                            embedded::kViewerJs.size() + embedded::kViewerCss.size() +
                            200 * (scene.hazards.size() + 1) + 64 * scene.map.size() / 1000 + 4096;
  const bool with_property = scene.map.hasProperty();
  std::size_t points = config.max_points > 0 ? std::min(config.max_points, scene.map.size()) : scene.map.size();
  std::size_t trajectory_bytes = 0;
  for (const auto& t : scene.trajectories) trajectory_bytes += 32 * t.positions.size();
  const std::size_t budget = config.max_bytes > fixed + trajectory_bytes ? config.max_bytes - fixed - trajectory_bytes : 0;
  const std::size_t fit = budget / viewer::bytesPerPoint(with_property);
  if (points > fit) {
    if (!config.decimate_to_fit)
      fail(scene.source.empty() ? "viewer" : scene.source,
           fmt::format("{} map points make a {:.1f} MB page, over the {:.1f} MB limit; pass --max-points {}",
                       points, double(fixed + trajectory_bytes + points * viewer::bytesPerPoint(with_property)) / 1048576.0,
                       double(config.max_bytes) / 1048576.0, fit));
    points = fit;
  }
  const viewer::EncodedPoints e = viewer::encodePoints(scene, points);
  std::string blocks = dataBlock("hazmap-positions", e.positions) + dataBlock("hazmap-colors", e.colors);
  if (e.has_property) blocks += dataBlock("hazmap-property", e.property);
  std::string html = fillTemplate(embedded::kViewerPage,
                                  {{"TITLE", htmlEscape(scene.title)},
                                   {"STYLE", std::string(embedded::kViewerCss)},
                                   {"META_JSON", scriptSafe(metaJson(scene, config, e).dump())},
                                   {"DATA_BLOCKS", blocks},
                                   {"THREE_JS", scriptSafe(three)},
                                   {"ORBIT_CONTROLS_JS", scriptSafe(orbit)},
                                   {"VIEWER_JS", scriptSafe(std::string(embedded::kViewerJs))},
                                   {"LIVE_JS", config.live ? scriptSafe(std::string(embedded::kViewerLiveJs)) : ""}});
  if (report) *report = {e.total, e.embedded, html.size()};
  return html;
}

std::string viewerHazardsJson(const std::vector<Hazard>& hazards, const ClassTable& classes,
                              const MapColorConfig& colors) {
  return hazardsMeta(hazards, classes, colors).dump();
}

ViewerReport writeViewer(const std::filesystem::path& path, const ViewerScene& scene, const ViewerConfig& config) {
  ViewerReport report;
  const std::string html = viewerHtml(scene, config, &report);
  writeTextAtomically(path, html);
  return report;
}

}  // namespace hazmap
