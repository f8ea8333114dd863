#include "hazmap/demo/demo_index.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "hazmap/core/error.hpp"
#include "hazmap/eval/trajectory_metrics.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/map/render.hpp"

namespace hazmap {

namespace {

constexpr const char* kStyle =
    "body{font:15px/1.5 'DejaVu Sans',system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222}"
    "table{border-collapse:collapse;margin:1em 0}th,td{padding:4px 10px;border-bottom:1px solid #ddd;"
    "text-align:right}th:first-child,td:first-child{text-align:left}thead th{background:#f2f4f7}"
    "a{color:#1d5fd1}img{max-width:100%;border:1px solid #ddd;margin:0.5em 0}.note{color:#666}";

std::string rowsHtml(const std::vector<DemoRow>& rows, const std::string& folder) {
  std::string s;
  for (const DemoRow& r : rows) {
    const std::string method = toString(r.method);
    const std::string rate = r.method == SlamMethod::Odometry ? "–" : fmt::format("{:.1f}", r.frames_per_s);
    s += fmt::format(
        "<tr><td>{}</td><td>{:.3f}</td><td><b>{:.3f}</b></td><td>{:.3f}</td><td>{}</td><td>{}</td>"
        "<td><a href=\"{}{}/viewer.html\">3D viewer</a> · <a href=\"{}{}/map_top.png\">map</a> · "
        "<a href=\"{}{}/trajectory.png\">trajectory</a></td></tr>\n",
        paperRowTitle(r.method), paperMapError(r.method), r.map_error_m, r.ate_m, rate, r.loops, folder, method,
        folder, method, folder, method);
  }
  return s;
}

std::string tableHtml(const std::string& caption, const std::vector<DemoRow>& rows, const std::string& folder,
                      const std::string& montage) {
  return fmt::format(
      "<h2>{}</h2>\n<table><thead><tr><th>Method</th><th>paper [m]</th><th>map error [m]</th><th>ATE [m]</th>"
      "<th>frames/s</th><th>loops</th><th>open</th></tr></thead><tbody>\n{}</tbody></table>\n"
      "<a href=\"{}\"><img src=\"{}\" alt=\"{}\"></a>\n",
      caption, rowsHtml(rows, folder), montage, montage, caption);
}

std::string errorPlotHtml(const std::string& png) {
  return fmt::format("<a href=\"{0}\"><img src=\"{0}\" alt=\"trajectory error against distance travelled\"></a>\n", png);
}

}  // namespace

std::string demoIndexHtml(const DemoReport& report, bool frame_to_map) {
  std::string body = fmt::format(
      "<h1>hazmap demo</h1>\n<p>The paper's experiment, simulated: {} frames over a {:.0f} m route. Map error is the "
      "paper's Table 2 metric (mean distance to the map built from the true poses). Each method's "
      "<b>3D viewer</b> opens offline in this browser.</p>\n",
      report.frames, report.route_length_m);
  body += tableHtml("Table 2 — the paper's set-up (ICP frame to frame)", report.rows, "", "maps_side_by_side.png");
  body += errorPlotHtml("trajectory_error.png");
  if (frame_to_map && !report.map_rows.empty()) {
    body += tableHtml("hazmap's tracking (frame to local map)", report.map_rows, "frame-to-map/",
                      "maps_side_by_side_frame_to_map.png");
    body += errorPlotHtml("trajectory_error_frame_to_map.png");
  }
  body += "<p class=\"note\">Numbers: table2.json. Simulated sequence: sequence/.</p>\n";
  return fmt::format("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>hazmap demo</title>"
                     "<style>{}</style></head>\n<body>\n{}</body></html>\n",
                     kStyle, body);
}

namespace {

std::string meanSd(const SeedStats& s) { return fmt::format("{:.3f} ± {:.3f}", s.mean, s.sd); }

// Per seed, one row of map errors per set-up.
std::string perSeedHtml(const SeedsReport& report) {
  std::string s = "<h2>Map error [m] per seed</h2>\n<table><thead><tr><th>seed</th><th>set-up</th>";
  for (const DemoRow& r : report.per_seed.front().rows) s += "<th>" + std::string(toString(r.method)) + "</th>";
  s += "<th>open</th></tr></thead><tbody>\n";
  for (std::size_t k = 0; k < report.per_seed.size(); ++k) {
    const DemoReport& r = report.per_seed[k];
    for (const auto* rows : {&r.rows, &r.map_rows}) {
      if (rows->empty()) continue;
      s += fmt::format("<tr><td>{}</td><td>{}</td>", report.seeds[k], rows == &r.rows ? "paper's" : "frame to map");
      for (const DemoRow& row : *rows) s += fmt::format("<td>{:.3f}</td>", row.map_error_m);
      s += fmt::format("<td><a href=\"seed-{}/index.html\">seed {}</a></td></tr>\n", report.seeds[k], report.seeds[k]);
    }
  }
  return s + "</tbody></table>\n";
}

}  // namespace

std::string seedsIndexHtml(const SeedsReport& report) {
  std::string body = fmt::format(
      "<h1>hazmap demo over {} seeds</h1>\n<p>Map error (the paper's Table 2 metric) and ATE as mean ± sample "
      "standard deviation over seeds {}. Numbers: table2.json.</p>\n<table><thead><tr><th>Method</th><th>paper [m]</th>"
      "<th>paper's set-up [m]</th><th>ATE [m]</th><th>frame to map [m]</th><th>ATE [m]</th></tr></thead><tbody>\n",
      report.seeds.size(), fmt::join(report.seeds, ", "));
  for (const auto& a : report.aggregate) {
    if (a.setup != DemoSetUp::FrameToFrame) continue;
    std::string f2m = "<td>–</td><td>–</td>";
    for (const auto& b : report.aggregate)
      if (b.setup == DemoSetUp::FrameToMap && b.method == a.method)
        f2m = fmt::format("<td><b>{}</b></td><td>{}</td>", meanSd(b.map_error_m), meanSd(b.ate_m));
    body += fmt::format("<tr><td>{}</td><td>{:.3f}</td><td><b>{}</b></td><td>{}</td>{}</tr>\n", paperRowTitle(a.method),
                        paperMapError(a.method), meanSd(a.map_error_m), meanSd(a.ate_m), f2m);
  }
  body += "</tbody></table>\n";
  if (!report.per_seed.empty()) body += perSeedHtml(report);
  return fmt::format("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>hazmap demo, seeds</title>"
                     "<style>{}</style></head>\n<body>\n{}</body></html>\n",
                     kStyle, body);
}

void writeSeedsIndex(const std::filesystem::path& out_dir, const SeedsReport& report) {
  writeTextAtomically(out_dir / "index.html", seedsIndexHtml(report));
}

void writeMethodErrorPlot(const std::filesystem::path& png, const Trajectory& truth,
                          const std::vector<SlamResult>& results, const std::string& title) {
  std::vector<ErrorSeries> series;
  const std::vector<double> distance = distanceTravelled(truth);
  for (std::size_t k = 0; k < results.size(); ++k) {
    if (results[k].estimate.size() != truth.size()) continue;
    std::vector<double> errors;
    try {
      errors = computeApe(truth, results[k].estimate, Alignment::SE3).errors;
    } catch (const Error&) {  // a straight route cannot be aligned rotationally
      errors = computeApe(truth, results[k].estimate, Alignment::None).errors;
    }
    series.push_back({toString(results[k].method), distance, errors, seriesColor(k)});
  }
  if (series.empty()) return;
  ErrorPlotConfig config;
  config.title = title;
  writePng(png, renderErrorPlot(series, config));
}

void writeDemoIndex(const std::filesystem::path& out_dir, const DemoReport& report, bool frame_to_map) {
  writeTextAtomically(out_dir / "index.html", demoIndexHtml(report, frame_to_map));
}

}  // namespace hazmap
