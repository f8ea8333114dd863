#include "hazmap/map/category_plot.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "canvas.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {

using figure::Align;
using figure::Canvas;
using figure::TextStyle;

namespace {

constexpr Rgb kText{30, 30, 30};
constexpr Rgb kGrid{228, 228, 228};
constexpr Rgb kAxis{110, 110, 110};

bool drawable(double v, bool log_y) { return std::isfinite(v) && (!log_y || v > 0); }

struct Frame {
  double x0, y0, x1, y1;   // plot area in pixels
  double lo, hi;           // y range (log10 of it on a log axis)
  std::size_t n;           // categories
  bool log_y;
  double px(std::size_t i) const { return x0 + (static_cast<double>(i) + 0.5) / static_cast<double>(n) * (x1 - x0); }
  double py(double v) const {
    const double t = log_y ? std::log10(v) : v;
    return y1 - (t - lo) / (hi - lo) * (y1 - y0);
  }
};

// Y range over every drawable value: whole decades on a log axis, 0-based with 10 % on a linear one.
std::pair<double, double> yRange(const std::vector<CategorySeries>& series, bool log_y) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : series)
    for (double v : s.values)
      if (drawable(v, log_y)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (!(lo <= hi)) return {log_y ? -3.0 : 0.0, log_y ? 0.0 : 1.0};
  if (!log_y) return {std::min(0.0, lo), hi > 0 ? hi * 1.1 : 1.0};
  const double a = std::floor(std::log10(lo)), b = std::ceil(std::log10(hi));
  return {a, b > a ? b : a + 1};
}

void drawYTicks(Canvas& c, const Frame& f) {
  const TextStyle tick{12, {70, 70, 70}, false, Align::Right};
  auto mark = [&](double v, bool label) {
    const double Y = std::round(f.py(v)) + 0.5;
    c.line(f.x0, Y, f.x1, Y, kGrid);
    c.line(f.x0 - 4, Y, f.x0, Y, kAxis);
    if (label) c.text(f.x0 - 7, Y + 4, figure::formatNumber(v), tick);
  };
  if (f.log_y) {
    for (double d = f.lo; d <= f.hi + 1e-9; d += 1)
      for (double m : {1.0, 2.0, 5.0})
        if (d + std::log10(m) <= f.hi + 1e-9) mark(m * std::pow(10.0, d), true);
    return;
  }
  const double step = figure::niceStep(f.hi - f.lo, 6);
  for (double y = std::ceil(f.lo / step) * step; y <= f.hi + 1e-9; y += step) mark(y, true);
}

}  // namespace

Image renderCategoryPlot(const std::vector<CategorySeries>& series, const CategoryPlotConfig& config) {
  const std::size_t n = config.categories.size();
  if (n == 0) fail("category plot", "no categories");
  if (config.width < 300 || config.height < 200) fail("category plot", "image is too small");
  for (const auto& s : series)
    if (s.values.size() != n)
      fail("category plot", fmt::format("{}: {} values for {} categories", s.label, s.values.size(), n));
  const auto [lo, hi] = yRange(series, config.log_y);
  Canvas c(config.width, config.height);
  const Frame f{76, 46, config.width - 16.0, config.height - 74.0, lo, hi, n, config.log_y};
  drawYTicks(c, f);
  const TextStyle tick{12, {70, 70, 70}, false, Align::Center};
  for (std::size_t i = 0; i < n; ++i) {
    const double X = std::round(f.px(i)) + 0.5;
    c.line(X, f.y0, X, f.y1, kGrid);
    c.text(X, f.y1 + 18, config.categories[i], tick);
  }
  c.strokeRect(std::round(f.x0) + 0.5, std::round(f.y0) + 0.5, std::round(f.x1 - f.x0), std::round(f.y1 - f.y0), kAxis);
  c.text((f.x0 + f.x1) / 2, f.y1 + 42, config.x_label, {13, kText, false, Align::Center});
  c.verticalText(f.x0 - 56, (f.y0 + f.y1) / 2, config.y_label + (config.log_y ? " (log)" : ""), {13, kText});
  c.text(f.x0, f.y0 - 14, config.title, {15, kText, true});
  std::vector<figure::LegendEntry> legend;
  for (const auto& s : series) {
    std::vector<std::pair<double, double>> line;
    for (std::size_t i = 0; i < n; ++i) {
      const double v = s.values[i];
      const double nan = std::numeric_limits<double>::quiet_NaN();
      line.emplace_back(drawable(v, config.log_y) ? std::pair{f.px(i), f.py(v)} : std::pair{nan, nan});
    }
    c.polyline(line, s.color, 2.0);
    for (const auto& [x, y] : line)
      if (std::isfinite(x)) c.fillCircle(x, y, 3.5, s.color);
    legend.push_back({s.color, s.label, true});
  }
  // Top left: the errors grow with the noise, so the left end of the curves is low.
  figure::drawLegend(c, f.x0 + 6, f.y0 + 6, legend, 12.0, /*anchor_left=*/true);
  return c.toImage();
}

}  // namespace hazmap
