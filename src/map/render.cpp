#include "hazmap/map/render.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include "hazmap/core/error.hpp"

namespace hazmap {

namespace {

constexpr Rgb kBlack{0, 0, 0};
constexpr Rgb kWhite{255, 255, 255};
constexpr Rgb kGrid{225, 225, 225};
constexpr Rgb kAxis{90, 90, 90};

// 1, 2 or 5 × 10^k closest above range / target.
double niceStep(double range, double target) {
  if (!(range > 0) || !std::isfinite(range)) return 1.0;
  const double raw = range / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double norm = raw / mag;
  return (norm < 1.5 ? 1.0 : norm < 3.0 ? 2.0 : norm < 7.0 ? 5.0 : 10.0) * mag;
}

std::string formatNumber(double v) {
  if (std::abs(v) < 1e-9) v = 0.0;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

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

// A white box with a border and one line per (colour, label) entry.
void drawLegend(Image& img, int right, int top, const std::vector<std::pair<Rgb, std::string>>& entries,
                int scale) {
  if (entries.empty()) return;
  const int line_h = 10 * scale + 4;
  int w = 0;
  for (const auto& e : entries) w = std::max(w, textWidth(e.second, scale));
  const int box_w = w + 18 * scale + 16;
  const int box_h = int(entries.size()) * line_h + 10;
  const int x0 = right - box_w, y0 = top;
  fillRect(img, x0, y0, x0 + box_w, y0 + box_h, kWhite);
  drawRect(img, x0, y0, x0 + box_w, y0 + box_h, kAxis, 1);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const int y = y0 + 6 + int(i) * line_h;
    fillRect(img, x0 + 6, y + 2, x0 + 6 + 14 * scale, y + 2 + 6 * scale, entries[i].first);
    drawText(img, x0 + 12 + 14 * scale, y, entries[i].second, kBlack, scale);
  }
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
                    const TopDownConfig& config) {
  if (!(config.pixels_per_metre > 0)) fail("top-down render: pixels_per_metre", "must be > 0");
  if (config.max_size_px < 16) fail("top-down render: max_size_px", "must be >= 16");
  const auto visible = [&](const Eigen::Vector3f& p) {
    return p.allFinite() && (!config.clip_above || p.z() <= *config.clip_above);
  };
  // Property cells drawn in colour: all of them, or (when hazards are given and
  // hazard_cells_only is set) those inside a hazard of their class; the rest are drawn like
  // plain cells, so isolated false labels do not speckle the map.
  const auto highlighted = [&](std::size_t i) {
    if (!table.isProperty(map.classes[i])) return false;
    if (hazards.empty() || !config.hazard_cells_only) return true;
    const Eigen::Vector3d p = map.points[i].cast<double>();
    for (const auto& h : hazards)
      if (h.label == map.classes[i] && (p.array() >= h.min.array() - 1e-6).all() &&
          (p.array() <= h.max.array() + 1e-6).all())
        return true;
    return false;
  };
  ViewBox view;
  if (config.view) {
    view = sane(*config.view);
  } else {
    LabeledCloud shown;
    for (std::size_t i = 0; i < map.size(); ++i)
      if (visible(map.points[i])) shown.points.push_back(map.points[i]);
    view = viewOf(shown, trajectory, 1.0);
  }
  const Eigen::Vector2d span = view.max - view.min;
  const double ppm = std::min(config.pixels_per_metre, double(config.max_size_px) / span.maxCoeff());
  const int map_w = std::max(1, int(std::ceil(span.x() * ppm)));
  const int map_h = std::max(1, int(std::ceil(span.y() * ppm)));
  const int title_h = config.title.empty() ? 0 : textHeight(config.title, 2) + 12;
  const int m = config.margin_px;

  // Legend entries (property classes present, then the trajectory) and the footer that holds
  // them with the scale bar, below the map so that nothing covers map content.
  std::vector<ClassId> seen;
  for (std::size_t i = 0; i < map.size(); ++i)
    if (visible(map.points[i]) && highlighted(i) &&
        std::find(seen.begin(), seen.end(), map.classes[i]) == seen.end())
      seen.push_back(map.classes[i]);
  std::sort(seen.begin(), seen.end());
  std::vector<std::pair<Rgb, std::string>> legend;
  for (ClassId id : seen) legend.emplace_back(propertyColor(table.at(id), config.colors), table.at(id).name);
  if (!trajectory.empty()) legend.emplace_back(config.trajectory, "trajectory");
  if (!config.draw_legend) legend.clear();
  const double bar_m = niceStep(span.x(), 5.0);
  const int bar_px = int(std::lround(bar_m * ppm));
  const std::string bar_label = formatNumber(bar_m) + " m";
  std::vector<std::pair<int, int>> slots;  // (x, row) of each footer item; item 0 = scale bar
  int footer_rows = 0;
  {
    const int usable = map_w;
    int x = 0, row = 0;
    const auto place = [&](int w) {
      if (x > 0 && x + w > usable) {
        x = 0;
        ++row;
      }
      slots.emplace_back(x, row);
      x += w + 16;
    };
    if (config.draw_scale_bar) place(bar_px + 8 + textWidth(bar_label, 1));
    for (const auto& e : legend) place(20 + textWidth(e.second, 1));
    footer_rows = slots.empty() ? 0 : row + 1;
  }
  const int footer_h = footer_rows * 18;
  Image img(map_w + 2 * m, map_h + 2 * m + title_h + footer_h, config.background);
  if (!config.title.empty()) drawText(img, m, 8, config.title, kBlack, 2);
  const auto px = [&](double x) { return m + (x - view.min.x()) * ppm; };
  const auto py = [&](double y) { return title_h + m + (view.max.y() - y) * ppm; };

  // Plain points: the highest one per pixel decides the grey.
  std::vector<float> zbuf(std::size_t(map_w) * std::size_t(map_h), -std::numeric_limits<float>::infinity());
  std::vector<float> heights;
  // Pixel span [x0, x1) × [y0, y1) (map-area coordinates) covered by a point's cell.
  const double half = 0.5 * std::max(0.0, config.cell_size);
  const auto footprint = [&](const Eigen::Vector3f& p, int min_px) {
    // Edges are rounded (not floored) so that neighbouring cells whose float centroids land a
    // hair either side of a pixel boundary still share that boundary: no one-pixel seams.
    int x0 = int(std::lround((p.x() - half - view.min.x()) * ppm));
    int x1 = std::max(x0 + 1, int(std::lround((p.x() + half - view.min.x()) * ppm)));
    int y0 = int(std::lround((view.max.y() - p.y() - half) * ppm));
    int y1 = std::max(y0 + 1, int(std::lround((view.max.y() - p.y() + half) * ppm)));
    if (x1 - x0 < min_px) {
      const int c = int(std::floor((p.x() - view.min.x()) * ppm));
      x0 = c - min_px / 2;
      x1 = x0 + min_px;
    }
    if (y1 - y0 < min_px) {
      const int c = int(std::floor((view.max.y() - p.y()) * ppm));
      y0 = c - min_px / 2;
      y1 = y0 + min_px;
    }
    return std::array<int, 4>{x0, y0, x1, y1};
  };
  for (std::size_t i = 0; i < map.size(); ++i) {
    const Eigen::Vector3f& p = map.points[i];
    if (!visible(p) || highlighted(i)) continue;
    const auto [x0, y0, x1, y1] = footprint(p, 1);
    bool inside = false;
    for (int y = std::max(0, y0); y < std::min(map_h, y1); ++y)
      for (int x = std::max(0, x0); x < std::min(map_w, x1); ++x) {
        float& z = zbuf[std::size_t(y) * std::size_t(map_w) + std::size_t(x)];
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
    lo = at(config.colors.low_percentile);
    hi = at(config.colors.high_percentile);
    if (hi - lo < 1e-3) {  // a flat map: mid grey rather than the darkest shade
      lo -= 0.5;
      hi = lo + 1.0;
    }
  }
  for (int y = 0; y < map_h; ++y)
    for (int x = 0; x < map_w; ++x) {
      const float z = zbuf[std::size_t(y) * std::size_t(map_w) + std::size_t(x)];
      if (std::isfinite(z)) img.set(m + x, title_h + m + y, greyForHeight(z, lo, hi, config.colors));
    }

  // Property cells on top, at least a few pixels wide so that thin hazards stay visible.
  const int min_px = std::max(1, 2 * config.property_point_px - 1);
  for (std::size_t i = 0; i < map.size(); ++i) {
    const Eigen::Vector3f& p = map.points[i];
    const ClassInfo* info = table.find(map.classes[i]);
    if (!visible(p) || !info || !highlighted(i)) continue;
    const Rgb c = propertyColor(*info, config.colors);
    const auto [x0, y0, x1, y1] = footprint(p, min_px);
    fillRect(img, std::max(0, x0) + m, std::max(0, y0) + title_h + m, std::min(map_w, x1) + m,
             std::min(map_h, y1) + title_h + m, c);
  }

  // Trajectory.
  for (std::size_t i = 1; i < trajectory.size(); ++i)
    drawLine(img, px(trajectory[i - 1].x()), py(trajectory[i - 1].y()), px(trajectory[i].x()),
             py(trajectory[i].y()), config.trajectory, 3);
  if (!trajectory.empty()) {
    fillCircle(img, px(trajectory.front().x()), py(trajectory.front().y()), 5, {0, 160, 60});
    const double ex = px(trajectory.back().x()), ey = py(trajectory.back().y());
    fillRect(img, int(ex) - 4, int(ey) - 4, int(ex) + 5, int(ey) + 5, kBlack);
  }

  // Hazard rings and numbers.
  for (const auto& h : hazards) {
    const ClassInfo* info = table.find(h.label);
    const Rgb c = info ? darker(propertyColor(*info, config.colors)) : kBlack;
    const double r = 0.5 * std::max(h.extent().x(), h.extent().y()) * ppm + 6.0;
    const double cx = px(h.centroid.x()), cy = py(h.centroid.y());
    drawCircle(img, cx, cy, r, c, 2);
    if (config.draw_hazard_labels) {
      const std::string label = "#" + std::to_string(h.id);
      const int tx = int(cx + r * 0.72) + 2, ty = int(cy - r * 0.72) - 12;
      fillRect(img, tx - 1, ty - 1, tx + textWidth(label, 1) + 1, ty + 11, kWhite);
      drawText(img, tx, ty, label, kBlack, 1);
    }
  }

  // Footer: scale bar, then the legend entries.
  const int fy = title_h + 2 * m + map_h - m / 2;
  std::size_t slot = 0;
  if (config.draw_scale_bar) {
    const int x0 = m + slots[slot].first, y0 = fy + slots[slot].second * 18 + 8;
    ++slot;
    fillRect(img, x0, y0, x0 + bar_px, y0 + 3, kBlack);
    fillRect(img, x0, y0 - 5, x0 + 2, y0 + 3, kBlack);
    fillRect(img, x0 + bar_px - 2, y0 - 5, x0 + bar_px, y0 + 3, kBlack);
    drawText(img, x0 + bar_px + 8, y0 - 4, bar_label, kBlack, 1);
  }
  for (const auto& [color, label] : legend) {
    const int x0 = m + slots[slot].first, y0 = fy + slots[slot].second * 18 + 2;
    ++slot;
    fillRect(img, x0, y0 + 1, x0 + 14, y0 + 9, color);
    drawText(img, x0 + 20, y0, label, kBlack, 1);
  }
  return img;
}

// ---- trajectory plot ---------------------------------------------------------------------------

namespace {

struct Axes {
  int x0, y0, x1, y1;  // pixel box of the plot area
  double xmin, xmax, ymin, ymax;
  double px(double x) const { return x0 + (x - xmin) / (xmax - xmin) * (x1 - x0); }
  double py(double y) const { return y1 - (y - ymin) / (ymax - ymin) * (y1 - y0); }
};

void drawAxes(Image& img, const Axes& a, const std::string& xlabel, const std::string& ylabel,
              const std::string& title) {
  const double xs = niceStep(a.xmax - a.xmin, 6), ys = niceStep(a.ymax - a.ymin, 6);
  for (double x = std::ceil(a.xmin / xs) * xs; x <= a.xmax + 1e-9; x += xs) {
    const int X = int(std::lround(a.px(x)));
    fillRect(img, X, a.y0, X + 1, a.y1, kGrid);
    const std::string t = formatNumber(x);
    drawText(img, X - textWidth(t, 1) / 2, a.y1 + 6, t, kAxis, 1);
  }
  for (double y = std::ceil(a.ymin / ys) * ys; y <= a.ymax + 1e-9; y += ys) {
    const int Y = int(std::lround(a.py(y)));
    fillRect(img, a.x0, Y, a.x1, Y + 1, kGrid);
    const std::string t = formatNumber(y);
    drawText(img, a.x0 - 6 - textWidth(t, 1), Y - 4, t, kAxis, 1);
  }
  drawRect(img, a.x0, a.y0, a.x1 + 1, a.y1 + 1, kAxis, 1);
  drawText(img, (a.x0 + a.x1) / 2 - textWidth(xlabel, 1) / 2, a.y1 + 22, xlabel, kBlack, 1);
  drawText(img, a.x0 - 10, a.y0 - 16, ylabel, kBlack, 1);
  drawText(img, a.x0, a.y0 - 40, title, kBlack, 2);
}

}  // namespace

Image renderTrajectoryPlot(const std::vector<PlotSeries>& series,
                           const std::vector<std::pair<PlotSeries, std::vector<double>>>& errors,
                           const TrajectoryPlotConfig& config) {
  if (config.width < 200 || config.height < 150) fail("trajectory plot", "image is too small");
  Image img(config.width, config.height, kWhite);
  const int panel_w = errors.empty() ? config.width : config.width / 2;

  // Left: top-down, equal axes.
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
  Axes a{70, 60, panel_w - 30, config.height - 50, xmin, xmax, ymin, ymax};
  {
    // Pad 5 % and make metres per pixel equal on both axes.
    const double w = std::max(xmax - xmin, 1.0) * 1.1, h = std::max(ymax - ymin, 1.0) * 1.1;
    const double mpp = std::max(w / (a.x1 - a.x0), h / (a.y1 - a.y0));
    const double cx = 0.5 * (xmin + xmax), cy = 0.5 * (ymin + ymax);
    a.xmin = cx - 0.5 * mpp * (a.x1 - a.x0);
    a.xmax = cx + 0.5 * mpp * (a.x1 - a.x0);
    a.ymin = cy - 0.5 * mpp * (a.y1 - a.y0);
    a.ymax = cy + 0.5 * mpp * (a.y1 - a.y0);
  }
  drawAxes(img, a, "x [m]", "y [m]", config.title);
  std::vector<std::pair<Rgb, std::string>> legend;
  for (const auto& s : series) {
    for (std::size_t i = 1; i < s.positions.size(); ++i)
      drawLine(img, a.px(s.positions[i - 1].x()), a.py(s.positions[i - 1].y()), a.px(s.positions[i].x()),
               a.py(s.positions[i].y()), s.color, s.thickness);
    if (!s.positions.empty())
      fillCircle(img, a.px(s.positions.front().x()), a.py(s.positions.front().y()), 4, s.color);
    legend.emplace_back(s.color, s.label);
  }
  drawLegend(img, a.x1 - 4, a.y0 + 4, legend, 1);

  if (!errors.empty()) {
    double n = 1, emax = 0;
    for (const auto& [s, e] : errors) {
      n = std::max(n, double(e.size()));
      for (double v : e)
        if (std::isfinite(v)) emax = std::max(emax, v);
    }
    Axes b{panel_w + 70, 60, config.width - 30, config.height - 50, 0, std::max(1.0, n - 1), 0,
           emax > 0 ? emax * 1.1 : 1.0};
    drawAxes(img, b, "frame", "error [m]", config.error_title);
    std::vector<std::pair<Rgb, std::string>> elegend;
    for (const auto& [s, e] : errors) {
      for (std::size_t i = 1; i < e.size(); ++i)
        drawLine(img, b.px(double(i - 1)), b.py(e[i - 1]), b.px(double(i)), b.py(e[i]), s.color, s.thickness);
      elegend.emplace_back(s.color, s.label);
    }
    drawLegend(img, b.x1 - 4, b.y0 + 4, elegend, 1);
  }
  return img;
}

Image renderTrajectoryComparison(const Trajectory& estimate, const Trajectory* ground_truth,
                                 const Trajectory* odometry, const TrajectoryPlotConfig& config) {
  if (estimate.empty()) fail("trajectory plot", "the estimate is empty");
  const Rgb blue{20, 80, 220}, orange{240, 140, 0};
  std::vector<PlotSeries> series;
  if (ground_truth) series.push_back({"ground truth", positionsOf(*ground_truth), kBlack, 2});
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

// ---- montage -----------------------------------------------------------------------------------

Image renderMontage(const std::vector<MontagePanel>& panels, const MontageConfig& config) {
  if (panels.empty()) fail("montage", "no panels");
  const int n = int(panels.size());
  const int cols = config.columns > 0 ? std::min(config.columns, n) : std::min(n, 3);
  const int rows = (n + cols - 1) / cols;
  int cell_w = 0, cell_h = 0, title_h = 0;
  for (const auto& p : panels) {
    cell_w = std::max({cell_w, p.image.width, textWidth(p.title, config.title_scale)});
    cell_h = std::max(cell_h, p.image.height);
    title_h = std::max(title_h, textHeight(p.title.empty() ? "X" : p.title, config.title_scale) + 8);
  }
  const int g = config.gap_px;
  const int top = config.title.empty() ? 0 : textHeight(config.title, config.title_scale + 1) + 2 * g;
  Image img(cols * cell_w + (cols + 1) * g, top + rows * (cell_h + title_h) + (rows + 1) * g, config.background);
  if (!config.title.empty()) drawText(img, g, g, config.title, kBlack, config.title_scale + 1);
  for (int i = 0; i < n; ++i) {
    const int col = i % cols, row = i / cols;
    const int x = g + col * (cell_w + g), y = top + g + row * (cell_h + title_h + g);
    drawText(img, x + (cell_w - textWidth(panels[i].title, config.title_scale)) / 2, y,
             panels[i].title, kBlack, config.title_scale);
    blit(img, panels[i].image, x + (cell_w - panels[i].image.width) / 2, y + title_h);
    drawRect(img, x + (cell_w - panels[i].image.width) / 2 - 1, y + title_h - 1,
             x + (cell_w + panels[i].image.width) / 2 + 1, y + title_h + panels[i].image.height + 1,
             kGrid, 1);
  }
  return img;
}

Image renderMapMontage(const std::vector<MapPanel>& panels, const ClassTable& table, TopDownConfig config,
                       const MontageConfig& montage) {
  if (panels.empty()) fail("map montage", "no panels");
  if (!config.view) {
    std::optional<ViewBox> all;
    for (const auto& p : panels) {
      static const LabeledCloud kEmpty;
      LabeledCloud shown;
      const LabeledCloud& cloud = p.map ? *p.map : kEmpty;
      for (const auto& q : cloud.points)
        if (q.allFinite() && (!config.clip_above || q.z() <= *config.clip_above)) shown.points.push_back(q);
      const ViewBox v = viewOf(shown, p.trajectory, 1.0);
      all = all ? unite(*all, v) : v;
    }
    config.view = all;
  }
  config.title.clear();
  std::vector<MontagePanel> rendered;
  static const LabeledCloud kEmpty;
  for (const auto& p : panels)
    rendered.push_back({p.title, renderTopDown(p.map ? *p.map : kEmpty, table, p.trajectory, p.hazards, config)});
  return renderMontage(rendered, montage);
}

}  // namespace hazmap
