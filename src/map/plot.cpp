// Line plots with Cairo: the trajectory comparison (trajectory.png) and the error against
// distance travelled (`hazmap eval --plot`).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "canvas.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/map/render.hpp"

namespace hazmap {

using namespace figure;  // Canvas, TextStyle, Align and the shared colours

namespace {

constexpr Rgb kGrid{228, 228, 228};
constexpr Rgb kAxis{110, 110, 110};

struct Axes {
  double x0, y0, x1, y1;  // pixel box of the plot area
  double xmin, xmax, ymin, ymax;
  double px(double x) const { return x0 + (x - xmin) / (xmax - xmin) * (x1 - x0); }
  double py(double y) const { return y1 - (y - ymin) / (ymax - ymin) * (y1 - y0); }
};

void drawAxes(Canvas& c, const Axes& a, const std::string& xlabel, const std::string& ylabel,
              const std::string& title) {
  const double xs = figure::niceStep(a.xmax - a.xmin, 8), ys = figure::niceStep(a.ymax - a.ymin, 6);
  const TextStyle tick{12, {70, 70, 70}, false, Align::Center};
  for (double x = std::ceil(a.xmin / xs) * xs; x <= a.xmax + 1e-9; x += xs) {
    const double X = std::round(a.px(x)) + 0.5;
    c.line(X, a.y0, X, a.y1, kGrid);
    c.line(X, a.y1, X, a.y1 + 5, kAxis);
    c.text(X, a.y1 + 19, figure::formatNumber(x), tick);
  }
  TextStyle right = tick;
  right.align = Align::Right;
  for (double y = std::ceil(a.ymin / ys) * ys; y <= a.ymax + 1e-9; y += ys) {
    const double Y = std::round(a.py(y)) + 0.5;
    c.line(a.x0, Y, a.x1, Y, kGrid);
    c.line(a.x0 - 5, Y, a.x0, Y, kAxis);
    c.text(a.x0 - 8, Y + 4, figure::formatNumber(y), right);
  }
  c.strokeRect(std::round(a.x0) + 0.5, std::round(a.y0) + 0.5, std::round(a.x1 - a.x0), std::round(a.y1 - a.y0), kAxis);
  c.text((a.x0 + a.x1) / 2, a.y1 + 40, xlabel, {13, kText, false, Align::Center});
  c.verticalText(a.x0 - 52, (a.y0 + a.y1) / 2, ylabel, {13, kText});
  c.text(a.x0, a.y0 - 16, title, {18, kText, true});
}

// Equal metres per pixel on both axes, 5 % padding.
Axes equalAxes(const std::vector<PlotSeries>& series, double x0, double y0, double x1, double y1) {
  double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
  for (const auto& s : series)
    for (const auto& p : s.positions)
      if (p.allFinite()) {
        xmin = std::min(xmin, p.x());
        xmax = std::max(xmax, p.x());
        ymin = std::min(ymin, p.y());
        ymax = std::max(ymax, p.y());
      }
  if (!(xmin <= xmax)) xmin = -1, xmax = 1, ymin = -1, ymax = 1;
  const double w = std::max(xmax - xmin, 1.0) * 1.1, h = std::max(ymax - ymin, 1.0) * 1.1;
  const double mpp = std::max(w / (x1 - x0), h / (y1 - y0));
  const double cx = 0.5 * (xmin + xmax), cy = 0.5 * (ymin + ymax);
  return {x0, y0, x1, y1, cx - 0.5 * mpp * (x1 - x0), cx + 0.5 * mpp * (x1 - x0),
          cy - 0.5 * mpp * (y1 - y0), cy + 0.5 * mpp * (y1 - y0)};
}

void clipTo(Canvas& c, const Axes& a) {
  cairo_save(c.cr());
  cairo_rectangle(c.cr(), a.x0, a.y0, a.x1 - a.x0, a.y1 - a.y0);
  cairo_clip(c.cr());
}

void drawTopView(Canvas& c, const std::vector<PlotSeries>& series, const Axes& a) {
  clipTo(c, a);
  for (const auto& s : series) {
    std::vector<std::pair<double, double>> line;
    for (const auto& p : s.positions) line.emplace_back(a.px(p.x()), a.py(p.y()));
    c.polyline(line, s.color, s.thickness);
    if (!s.positions.empty()) c.fillCircle(a.px(s.positions.front().x()), a.py(s.positions.front().y()), 4.5, s.color);
  }
  cairo_restore(c.cr());
  std::vector<figure::LegendEntry> legend;
  for (const auto& s : series) legend.push_back({s.color, s.label, true});
  figure::drawLegend(c, a.x1 - 8, a.y0 + 8, legend);
}

void drawErrorPanel(Canvas& c, const std::vector<std::pair<PlotSeries, std::vector<double>>>& errors,
                    double x0, double y0, double x1, double y1, const std::string& title) {
  double n = 1, emax = 0;
  for (const auto& [s, e] : errors) {
    n = std::max(n, double(e.size()));
    for (double v : e)
      if (std::isfinite(v)) emax = std::max(emax, v);
  }
  const Axes b{x0, y0, x1, y1, 0, std::max(1.0, n - 1), 0, emax > 0 ? emax * 1.1 : 1.0};
  drawAxes(c, b, "frame", "translation error [m]", title);
  clipTo(c, b);
  for (const auto& [s, e] : errors) {
    std::vector<std::pair<double, double>> line;
    for (std::size_t i = 0; i < e.size(); ++i) line.emplace_back(b.px(double(i)), b.py(e[i]));
    c.polyline(line, s.color, s.thickness);
  }
  cairo_restore(c.cr());
  std::vector<figure::LegendEntry> legend;
  for (const auto& [s, e] : errors) legend.push_back({s.color, s.label, true});
  figure::drawLegend(c, b.x1 - 8, b.y0 + 8, legend);
}

}  // namespace

Image renderTrajectoryPlot(const std::vector<PlotSeries>& series,
                           const std::vector<std::pair<PlotSeries, std::vector<double>>>& errors,
                           const TrajectoryPlotConfig& config) {
  if (config.width < 200 || config.height < 150) fail("trajectory plot", "image is too small");
  Canvas c(config.width, config.height);
  const double panel_w = errors.empty() ? config.width : config.width / 2.0;
  const Axes a = equalAxes(series, 80, 60, panel_w - 30, config.height - 60);
  drawAxes(c, a, "x [m]", "y [m]", config.title);
  drawTopView(c, series, a);
  if (!errors.empty()) drawErrorPanel(c, errors, panel_w + 80, 60, config.width - 30, config.height - 60, config.error_title);
  return c.toImage();
}

Image renderTrajectoryComparison(const Trajectory& estimate, const Trajectory* ground_truth,
                                 const Trajectory* odometry, const TrajectoryPlotConfig& config) {
  if (estimate.empty()) fail("trajectory plot", "the estimate is empty");
  const Rgb blue{20, 80, 220}, orange{240, 140, 0};
  std::vector<PlotSeries> series;
  if (ground_truth) series.push_back({"ground truth", positionsOf(*ground_truth), kBlack, 4.5});  // wider: visible under a good estimate
  if (odometry) series.push_back({"odometry", positionsOf(*odometry), orange, 2});
  series.push_back({"estimate", positionsOf(estimate), blue, 2});
  std::vector<std::pair<PlotSeries, std::vector<double>>> errors;
  if (ground_truth) {
    const auto errorsOf = [&](const Trajectory& t, const std::string& name) {
      if (t.size() != ground_truth->size())
        fail("trajectory plot", name + " has " + std::to_string(t.size()) + " poses but the ground truth has " +
                                    std::to_string(ground_truth->size()));
      std::vector<double> e(t.size());
      for (std::size_t i = 0; i < t.size(); ++i)
        e[i] = (t.poses[i].translation() - ground_truth->poses[i].translation()).norm();
      return e;
    };
    if (odometry) errors.emplace_back(PlotSeries{"odometry", {}, orange, 2}, errorsOf(*odometry, "odometry"));
    errors.emplace_back(PlotSeries{"estimate", {}, blue, 2}, errorsOf(estimate, "estimate"));
  }
  return renderTrajectoryPlot(series, errors, config);
}

std::vector<double> distanceTravelled(const Trajectory& trajectory) {
  std::vector<double> d(trajectory.size(), 0.0);
  for (std::size_t i = 1; i < trajectory.size(); ++i)
    d[i] = d[i - 1] + (trajectory.poses[i].translation() - trajectory.poses[i - 1].translation()).norm();
  return d;
}

Rgb seriesColor(std::size_t k) {
  // Colour-blind-safe (Okabe-Ito) with black last.
  static constexpr Rgb kPalette[] = {{0, 114, 178}, {230, 159, 0}, {0, 158, 115}, {213, 94, 0},
                                     {204, 121, 167}, {86, 180, 233}, {120, 120, 120}, {0, 0, 0}};
  return kPalette[k % std::size(kPalette)];
}

Image renderErrorPlot(const std::vector<ErrorSeries>& series, const ErrorPlotConfig& config) {
  if (series.empty()) fail("error plot", "no series to draw");
  if (config.width < 300 || config.height < 200) fail("error plot", "image is too small");
  double dmax = 1, emax = 0;
  for (const auto& s : series) {
    if (s.distance_m.size() != s.error_m.size())
      fail("error plot", s.label + ": " + std::to_string(s.distance_m.size()) + " distances but " +
                             std::to_string(s.error_m.size()) + " errors");
    for (double d : s.distance_m)
      if (std::isfinite(d)) dmax = std::max(dmax, d);
    for (double e : s.error_m)
      if (std::isfinite(e)) emax = std::max(emax, e);
  }
  Canvas c(config.width, config.height);
  const Axes a{90, 60, config.width - 30.0, config.height - 64.0, 0, dmax, 0, emax > 0 ? emax * 1.1 : 1.0};
  drawAxes(c, a, "distance travelled [m]", "translation error [m]", config.title);
  clipTo(c, a);
  std::vector<figure::LegendEntry> legend;
  for (const auto& s : series) {
    std::vector<std::pair<double, double>> line;
    double sum = 0;
    for (std::size_t i = 0; i < s.error_m.size(); ++i) {
      line.emplace_back(a.px(s.distance_m[i]), a.py(s.error_m[i]));
      sum += s.error_m[i];
    }
    c.polyline(line, s.color, 2.0);
    legend.push_back({s.color, fmt::format("{} (mean {:.3f} m)", s.label, s.error_m.empty() ? 0.0 : sum / double(s.error_m.size())), true});
  }
  cairo_restore(c.cr());
  // Top left: errors usually grow with the distance, so the curves end high on the right.
  figure::drawLegend(c, a.x0 + 8, a.y0 + 8, legend, 13.0, /*anchor_left=*/true);
  return c.toImage();
}

}  // namespace hazmap
