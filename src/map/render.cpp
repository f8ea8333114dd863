// Top-down map render (map_top.png) with Cairo.
#include "hazmap/map/render.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "canvas.hpp"
#include "hazmap/core/error.hpp"

namespace hazmap {

using namespace figure;  // Canvas, TextStyle, Align and the shared colours

namespace {

constexpr Rgb kFrame{120, 120, 120};

Rgb darker(Rgb c, double f = 0.6) {
  return {std::uint8_t(c[0] * f), std::uint8_t(c[1] * f), std::uint8_t(c[2] * f)};
}

ViewBox sane(ViewBox v) {
  for (int k = 0; k < 2; ++k) {
    if (!std::isfinite(v.min[k]) || !std::isfinite(v.max[k]) || v.max[k] < v.min[k]) {
      v.min[k] = -1;
      v.max[k] = 1;
    }
    if (v.max[k] - v.min[k] < 1.0) {
      const double c = 0.5 * (v.min[k] + v.max[k]);
      v.min[k] = c - 0.5;
      v.max[k] = c + 0.5;
    }
  }
  return v;
}

// Which points are drawn and which of them in colour.
struct PointFilter {
  const LabeledCloud& map;
  const ClassTable& table;
  const std::vector<Hazard>& hazards;
  const TopDownConfig& config;

  bool visible(std::size_t i) const {
    const Eigen::Vector3f& p = map.points[i];
    return p.allFinite() && (!config.clip_above || p.z() <= *config.clip_above);
  }
  // Property cells drawn in colour: all of them, or (when hazards are given and
  // hazard_cells_only is set) those inside a hazard of their class; the rest are drawn like
  // plain cells, so isolated false labels do not speckle the map.
  bool highlighted(std::size_t i) const {
    if (!table.isProperty(map.classes[i])) return false;
    if (hazards.empty() || !config.hazard_cells_only) return true;
    const Eigen::Vector3d p = map.points[i].cast<double>();
    for (const auto& h : hazards)
      if (h.label == map.classes[i] && (p.array() >= h.min.array() - 1e-6).all() &&
          (p.array() <= h.max.array() + 1e-6).all())
        return true;
    return false;
  }
};

// Pixel layout: title band, y-axis labels on the left, the map, x-axis labels and the footer.
struct Layout {
  ViewBox view;
  double ppm = 1;
  int map_w = 1, map_h = 1, left = 0, top = 0, width = 0, height = 0, footer_top = 0;
  double px(double x) const { return left + (x - view.min.x()) * ppm; }
  double py(double y) const { return top + (view.max.y() - y) * ppm; }
};

Layout layoutFor(const ViewBox& view, const TopDownConfig& config, int footer_rows) {
  Layout l;
  l.view = view;
  const Eigen::Vector2d span = view.max - view.min;
  l.ppm = std::min(config.pixels_per_metre, double(config.max_size_px) / span.maxCoeff());
  l.map_w = std::max(1, int(std::ceil(span.x() * l.ppm)));
  l.map_h = std::max(1, int(std::ceil(span.y() * l.ppm)));
  const int m = config.margin_px;
  const int axis = config.draw_axes ? 44 : 0;
  l.left = m + axis;
  l.top = (config.title.empty() ? 0 : 34) + m / 2 + (config.draw_axes ? 6 : 0);
  l.footer_top = l.top + l.map_h + (config.draw_axes ? 30 : 8);
  l.width = l.left + l.map_w + m;
  l.height = l.footer_top + footer_rows * 24 + m / 2;
  return l;
}

// Footprint [x0, x1) × [y0, y1) in map-area pixels of a point's cell, at least min_px wide.
// Edges are rounded (not floored) so that neighbouring cells whose float centroids land a hair
// either side of a pixel boundary still share that boundary: no one-pixel seams.
std::array<int, 4> footprint(const Layout& l, const Eigen::Vector3f& p, double half, int min_px) {
  int x0 = int(std::lround((p.x() - half - l.view.min.x()) * l.ppm));
  int x1 = std::max(x0 + 1, int(std::lround((p.x() + half - l.view.min.x()) * l.ppm)));
  int y0 = int(std::lround((l.view.max.y() - p.y() - half) * l.ppm));
  int y1 = std::max(y0 + 1, int(std::lround((l.view.max.y() - p.y() + half) * l.ppm)));
  if (x1 - x0 < min_px) {
    x0 = int(std::floor((p.x() - l.view.min.x()) * l.ppm)) - min_px / 2;
    x1 = x0 + min_px;
  }
  if (y1 - y0 < min_px) {
    y0 = int(std::floor((l.view.max.y() - p.y()) * l.ppm)) - min_px / 2;
    y1 = y0 + min_px;
  }
  return {x0, y0, x1, y1};
}

// Plain points: the highest one per pixel decides the grey (written straight into the surface).
void drawPlainPoints(Canvas& canvas, const Layout& l, const PointFilter& f) {
  const double half = 0.5 * std::max(0.0, f.config.cell_size);
  std::vector<float> zbuf(std::size_t(l.map_w) * std::size_t(l.map_h), -std::numeric_limits<float>::infinity());
  std::vector<float> heights;
  for (std::size_t i = 0; i < f.map.size(); ++i) {
    if (!f.visible(i) || f.highlighted(i)) continue;
    const Eigen::Vector3f& p = f.map.points[i];
    const auto [x0, y0, x1, y1] = footprint(l, p, half, 1);
    bool inside = false;
    for (int y = std::max(0, y0); y < std::min(l.map_h, y1); ++y)
      for (int x = std::max(0, x0); x < std::min(l.map_w, x1); ++x) {
        float& z = zbuf[std::size_t(y) * std::size_t(l.map_w) + std::size_t(x)];
        z = std::max(z, p.z());
        inside = true;
      }
    if (inside) heights.push_back(p.z());
  }
  double lo = 0, hi = 1;
  if (!heights.empty()) {
    const auto at = [&](double q) {
      const std::size_t k = std::size_t(q * double(heights.size() - 1));
      std::nth_element(heights.begin(), heights.begin() + std::ptrdiff_t(k), heights.end());
      return double(heights[k]);
    };
    lo = at(f.config.colors.low_percentile);
    hi = at(f.config.colors.high_percentile);
    if (hi - lo < 1e-3) {  // a flat map: mid grey rather than the darkest shade
      lo -= 0.5;
      hi = lo + 1.0;
    }
  }
  std::uint32_t* pixels = canvas.pixels();
  const int stride = canvas.stride();
  for (int y = 0; y < l.map_h; ++y)
    for (int x = 0; x < l.map_w; ++x) {
      const float z = zbuf[std::size_t(y) * std::size_t(l.map_w) + std::size_t(x)];
      if (!std::isfinite(z)) continue;
      const Rgb c = greyForHeight(z, lo, hi, f.config.colors);
      pixels[(l.top + y) * stride + l.left + x] = 0xff000000u | std::uint32_t(c[0]) << 16 | std::uint32_t(c[1]) << 8 | c[2];
    }
  canvas.markDirty();
}

// Property cells on top, at least a few pixels wide so that thin hazards stay visible.
void drawPropertyCells(Canvas& canvas, const Layout& l, const PointFilter& f) {
  const double half = 0.5 * std::max(0.0, f.config.cell_size);
  const int min_px = std::max(1, 2 * f.config.property_point_px - 1);
  cairo_save(canvas.cr());
  cairo_rectangle(canvas.cr(), l.left, l.top, l.map_w, l.map_h);
  cairo_clip(canvas.cr());
  for (std::size_t i = 0; i < f.map.size(); ++i) {
    const ClassInfo* info = f.table.find(f.map.classes[i]);
    if (!info || !f.visible(i) || !f.highlighted(i)) continue;
    const auto [x0, y0, x1, y1] = footprint(l, f.map.points[i], half, min_px);
    canvas.fillRect(l.left + x0, l.top + y0, x1 - x0, y1 - y0, propertyColor(*info, f.config.colors));
  }
  cairo_restore(canvas.cr());
}

void drawTrajectory(Canvas& canvas, const Layout& l, const std::vector<Eigen::Vector3d>& trajectory, Rgb color) {
  if (trajectory.empty()) return;
  std::vector<std::pair<double, double>> line;
  for (const auto& p : trajectory) line.emplace_back(l.px(p.x()), l.py(p.y()));
  canvas.polyline(line, {255, 255, 255}, 5.0);  // a white halo keeps it readable over grey
  canvas.polyline(line, color, 2.5);
  canvas.fillCircle(l.px(trajectory.front().x()), l.py(trajectory.front().y()), 6, {0, 160, 60});
  canvas.strokeCircle(l.px(trajectory.front().x()), l.py(trajectory.front().y()), 6, {255, 255, 255}, 1.5);
  const double ex = l.px(trajectory.back().x()), ey = l.py(trajectory.back().y());
  canvas.fillRect(ex - 5, ey - 5, 10, 10, kBlack);
}

void drawHazards(Canvas& canvas, const Layout& l, const PointFilter& f) {
  for (const auto& h : f.hazards) {
    const ClassInfo* info = f.table.find(h.label);
    const Rgb c = info ? darker(propertyColor(*info, f.config.colors)) : kBlack;
    const double r = 0.5 * std::max(h.extent().x(), h.extent().y()) * l.ppm + 6.0;
    const double cx = l.px(h.centroid.x()), cy = l.py(h.centroid.y());
    canvas.strokeCircle(cx, cy, r, c, 2.0);
    if (!f.config.draw_hazard_labels) continue;
    const std::string label = "#" + std::to_string(h.id);
    const TextStyle style{12, kText, true};
    const double w = canvas.textWidth(label, style);
    const double tx = cx + r * 0.72 + 2, ty = cy - r * 0.72 - 4;
    canvas.fillRect(tx - 2, ty - 11, w + 4, 14, {255, 255, 255}, 0.85);
    canvas.text(tx, ty, label, style);
  }
}

// Ticks in metres under and left of the map, and a thin frame.
void drawMapAxes(Canvas& canvas, const Layout& l) {
  canvas.strokeRect(l.left - 0.5, l.top - 0.5, l.map_w + 1, l.map_h + 1, kFrame);
  const TextStyle style{11, {70, 70, 70}, false, Align::Center};
  const double step = figure::niceStep(std::max(l.view.max.x() - l.view.min.x(), l.view.max.y() - l.view.min.y()), 8);
  for (double x = std::ceil(l.view.min.x() / step) * step; x <= l.view.max.x() + 1e-9; x += step) {
    const double X = std::round(l.px(x)) + 0.5;
    canvas.line(X, l.top + l.map_h, X, l.top + l.map_h + 5, kFrame);
    canvas.text(X, l.top + l.map_h + 17, figure::formatNumber(x), style);
  }
  TextStyle right = style;
  right.align = Align::Right;
  for (double y = std::ceil(l.view.min.y() / step) * step; y <= l.view.max.y() + 1e-9; y += step) {
    const double Y = std::round(l.py(y)) + 0.5;
    canvas.line(l.left - 5, Y, l.left, Y, kFrame);
    canvas.text(l.left - 8, Y + 4, figure::formatNumber(y), right);
  }
  canvas.text(l.left + l.map_w, l.top + l.map_h + 17, "x [m]", {11, kText, true, Align::Right});
  canvas.verticalText(l.left - 36, l.top + l.map_h / 2.0, "y [m]", {11, kText, true});
}

std::vector<figure::LegendEntry> legendFor(const PointFilter& f, bool with_trajectory) {
  std::vector<ClassId> seen;
  for (std::size_t i = 0; i < f.map.size(); ++i)
    if (f.visible(i) && f.highlighted(i) && std::find(seen.begin(), seen.end(), f.map.classes[i]) == seen.end())
      seen.push_back(f.map.classes[i]);
  std::sort(seen.begin(), seen.end());
  std::vector<figure::LegendEntry> legend;
  for (ClassId id : seen) legend.push_back({propertyColor(f.table.at(id), f.config.colors), f.table.at(id).name});
  if (with_trajectory) legend.push_back({f.config.trajectory, "trajectory", true});
  legend.push_back({f.config.colors.grey_high, "no property (grey: height)"});
  return legend;
}

// Scale bar, then the legend entries in a row (wrapping) under the map.
struct FooterItem {
  double width;
  int row;
  double x;
};
std::vector<FooterItem> placeFooter(Canvas& canvas, const std::vector<figure::LegendEntry>& legend, double bar_w,
                                    double usable) {
  std::vector<FooterItem> items;
  double x = 0;
  int row = 0;
  const auto place = [&](double w) {
    if (x > 0 && x + w > usable) {
      x = 0;
      ++row;
    }
    items.push_back({w, row, x});
    x += w + 18;
  };
  place(bar_w);
  for (const auto& e : legend) place(24 + canvas.textWidth(e.label, {12, kText}));
  return items;
}

}  // namespace

std::vector<Eigen::Vector3d> positionsOf(const Trajectory& trajectory) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(trajectory.size());
  for (const auto& P : trajectory.poses) out.push_back(P.translation());
  return out;
}

ViewBox viewOf(const LabeledCloud& map, const std::vector<Eigen::Vector3d>& trajectory, double pad) {
  ViewBox v;
  v.min = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  v.max = -v.min;
  for (const auto& p : map.points)
    if (p.allFinite()) {
      v.min = v.min.cwiseMin(p.head<2>().cast<double>());
      v.max = v.max.cwiseMax(p.head<2>().cast<double>());
    }
  for (const auto& p : trajectory)
    if (p.allFinite()) {
      v.min = v.min.cwiseMin(p.head<2>());
      v.max = v.max.cwiseMax(p.head<2>());
    }
  if (!(v.min.array() <= v.max.array()).all()) return sane(v);
  v.min.array() -= pad;
  v.max.array() += pad;
  return sane(v);
}

ViewBox unite(const ViewBox& a, const ViewBox& b) {
  return {a.min.cwiseMin(b.min), a.max.cwiseMax(b.max)};
}

Image renderTopDown(const LabeledCloud& map, const ClassTable& table,
                    const std::vector<Eigen::Vector3d>& trajectory, const std::vector<Hazard>& hazards,
                    const TopDownConfig& config, TopDownFrame* frame) {
  if (!(config.pixels_per_metre > 0)) fail("top-down render: pixels_per_metre", "must be > 0");
  if (config.max_size_px < 16) fail("top-down render: max_size_px", "must be >= 16");
  const PointFilter filter{map, table, hazards, config};
  ViewBox view;
  if (config.view) {
    view = sane(*config.view);
  } else {
    LabeledCloud shown;
    for (std::size_t i = 0; i < map.size(); ++i)
      if (filter.visible(i)) shown.points.push_back(map.points[i]);
    view = viewOf(shown, trajectory, 1.0);
  }
  const std::vector<figure::LegendEntry> legend =
      config.draw_legend ? legendFor(filter, !trajectory.empty()) : std::vector<figure::LegendEntry>{};
  // Two passes over the layout: the footer's rows depend on the map's width.
  Layout l = layoutFor(view, config, 0);
  const double bar_m = figure::niceStep(view.max.x() - view.min.x(), 5.0);
  const double bar_w = config.draw_scale_bar ? bar_m * l.ppm + 30 : 0;
  Canvas probe(1, 1);
  const std::vector<FooterItem> items = placeFooter(probe, legend, bar_w, std::max(l.map_w, 300));
  const int rows = (config.draw_scale_bar || !legend.empty()) ? items.back().row + 1 : 0;
  l = layoutFor(view, config, rows);
  l.width = std::max(l.width, l.left + 300 + config.margin_px);

  Canvas canvas(l.width, l.height, config.background);
  if (!config.title.empty()) canvas.text(config.margin_px, 28, config.title, {20, kText, true});
  drawPlainPoints(canvas, l, filter);
  drawPropertyCells(canvas, l, filter);
  drawHazards(canvas, l, filter);
  drawTrajectory(canvas, l, trajectory, config.trajectory);
  if (config.draw_axes) drawMapAxes(canvas, l);
  std::size_t k = 0;
  const auto itemX = [&](std::size_t i) { return l.left + items[i].x; };
  const auto itemY = [&](std::size_t i) { return l.footer_top + 24.0 * items[i].row; };
  if (config.draw_scale_bar) figure::drawScaleBar(canvas, itemX(0) + 6, itemY(0) + 8, bar_m, l.ppm);
  for (const auto& e : legend) {
    ++k;
    const double x = itemX(k), y = itemY(k);
    if (e.line) canvas.line(x, y + 4, x + 18, y + 4, e.color, 3.0);
    else canvas.fillRect(x, y - 2, 18, 12, e.color);
    if (!e.line) canvas.strokeRect(x, y - 2, 18, 12, kFrame, 0.8);
    canvas.text(x + 24, y + 8, e.label, {12, kText});
  }
  if (frame) *frame = {view, l.ppm, {double(l.left), double(l.top)}};
  return canvas.toImage();
}

}  // namespace hazmap
