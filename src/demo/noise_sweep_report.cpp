// The noise sweep's table (markdown) and figure (PNG).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazmap/demo/noise_sweep.hpp"
#include "hazmap/map/category_plot.hpp"
#include "hazmap/map/render.hpp"

namespace hazmap {

namespace {

constexpr const char* kMethods[] = {"odometry", "icp", "icp+pgo", "property-icp", "property-icp+pgo"};

struct SetUpColumn {
  const char* key;
  const char* title;
};
constexpr SetUpColumn kSetUps[] = {{"frame_to_frame", "paper's set-up (frame to frame)"},
                                   {"frame_to_map", "frame to local map"}};

std::string cellText(const SweepPointResult& r, const char* setup, const char* method) {
  const auto s = r.cells.find(setup);
  if (s == r.cells.end()) return "–";
  const auto c = s->second.find(method);
  if (c == s->second.end()) return "–";
  const SeedStats& m = c->second.map_error_m;
  return m.n > 1 ? fmt::format("{:.3f} ± {:.3f}", m.mean, m.sd) : fmt::format("{:.3f}", m.mean);
}

std::string pointTitle(const SweepPointResult& r) {
  if (r.point.axis.empty()) return "defaults";
  if (r.point.axis == "combinations")
    return fmt::format("**{}**: {}", r.point.label, fmt::join(r.point.settings, ", "));
  return fmt::format("{} = {}", r.point.axis, r.point.label);
}

double meanOf(const SweepPointResult& r, const std::string& setup, const std::string& method) {
  const auto s = r.cells.find(setup);
  if (s == r.cells.end()) return std::numeric_limits<double>::quiet_NaN();
  const auto c = s->second.find(method);
  return c == s->second.end() ? std::numeric_limits<double>::quiet_NaN() : c->second.map_error_m.mean;
}

// One panel: the five methods' mean map error at the points of one axis, in one set-up.
Image panel(const NoiseSweepReport& report, const std::string& axis, const SetUpColumn& setup) {
  CategoryPlotConfig pc;
  pc.title = fmt::format("{} — {}", axis == "combinations" ? "combinations" : axis, setup.title);
  pc.x_label = axis == "combinations" ? "simulator settings" : axis;
  pc.y_label = "map error [m]";
  std::vector<const SweepPointResult*> members;
  for (const auto& r : report.points)
    if (r.point.axis == axis) members.push_back(&r);
  if (axis == "combinations") members.insert(members.begin(), &report.points.front());  // the defaults
  for (const auto* r : members) pc.categories.push_back(r->point.label);
  std::vector<CategorySeries> series;
  for (std::size_t m = 0; m < std::size(kMethods); ++m) {
    CategorySeries s{kMethods[m], {}, seriesColor(m)};
    for (const auto* r : members) s.values.push_back(meanOf(*r, setup.key, kMethods[m]));
    series.push_back(std::move(s));
  }
  return renderCategoryPlot(series, pc);
}

}  // namespace

std::string noiseSweepMarkdown(const NoiseSweepReport& report, const NoiseSweepConfig& config) {
  std::string s = fmt::format(
      "Map error [m] against the map from the true poses, scenario {}, seed{} {}, {}; mean{} over the seeds. "
      "ratio = ICP / property ICP (> 1: property ICP better), with PGO in brackets.\n\n",
      config.demo.scenario, config.seeds.size() > 1 ? "s" : "", fmt::join(config.seeds, ","),
      config.demo.frames ? fmt::format("first {} frames", config.demo.frames) : std::string("whole route"),
      config.seeds.size() > 1 ? " ± sd" : "");
  if (!config.base.empty()) s += fmt::format("Every point also sets: {}.\n\n", fmt::join(config.base, ", "));
  for (const SetUpColumn& setup : kSetUps) {
    bool any = false;
    for (const auto& r : report.points) any |= r.cells.count(setup.key) > 0;
    if (!any) continue;
    s += fmt::format("**{}**\n\n| point | {} | ratio |\n|---|---|---|---|---|---|---|\n", setup.title,
                     fmt::join(kMethods, " | "));
    for (const auto& r : report.points) {
      s += "| " + pointTitle(r) + " |";
      for (const char* m : kMethods) s += " " + cellText(r, setup.key, m) + " |";
      s += fmt::format(" {:.2f} ({:.2f}) |\n", r.ratio(setup.key, false), r.ratio(setup.key, true));
    }
    s += "\n";
  }
  return s;
}

void writeNoiseSweepPng(const std::filesystem::path& png, const NoiseSweepReport& report,
                        const NoiseSweepConfig& config) {
  std::vector<std::string> axes;
  for (const auto& r : report.points)
    if (!r.point.axis.empty() && std::find(axes.begin(), axes.end(), r.point.axis) == axes.end())
      axes.push_back(r.point.axis);
  if (axes.empty()) axes.push_back("combinations");
  std::vector<MontagePanel> panels;
  for (const SetUpColumn& setup : kSetUps) {
    if (setup.key == std::string("frame_to_map") && !config.demo.frame_to_map) continue;
    for (const auto& axis : axes) panels.push_back({"", panel(report, axis, setup)});
  }
  MontageConfig montage;
  montage.columns = static_cast<int>(axes.size());
  montage.title = fmt::format("hazmap noise sweep: map error of the five methods ({}, seed{} {}{})", config.demo.scenario,
                              config.seeds.size() > 1 ? "s" : "",
                              fmt::join(config.seeds, ","),
                              config.demo.frames ? fmt::format(", first {} frames", config.demo.frames) : "");
  writePng(png, renderMontage(panels, montage));
}

}  // namespace hazmap
