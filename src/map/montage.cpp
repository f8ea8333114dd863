// Several images side by side with titles (the demo's maps_side_by_side*.png).
#include <algorithm>

#include "canvas.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/map/render.hpp"

namespace hazmap {

using namespace figure;  // Canvas, TextStyle, Align and the shared colours

Image renderMontage(const std::vector<MontagePanel>& panels, const MontageConfig& config) {
  if (panels.empty()) fail("montage", "no panels");
  const int n = int(panels.size());
  const int cols = config.columns > 0 ? std::min(config.columns, n) : std::min(n, 3);
  const int rows = (n + cols - 1) / cols;
  const TextStyle panel_title{config.panel_title_size, kText, true, Align::Center};
  const TextStyle title{config.title_size, {20, 20, 20}, true};
  Canvas probe(1, 1);
  int cell_w = 0, cell_h = 0;
  for (const auto& p : panels) {
    cell_w = std::max({cell_w, p.image.width, int(probe.textWidth(p.title, panel_title)) + 8});
    cell_h = std::max(cell_h, p.image.height);
  }
  const int g = config.gap_px;
  const int title_h = int(config.panel_title_size * 1.6);
  const int top = config.title.empty() ? 0 : int(config.title_size * 1.6) + g;
  const int width = std::max(cols * cell_w + (cols + 1) * g, int(probe.textWidth(config.title, title)) + 2 * g);
  Canvas c(width, top + rows * (cell_h + title_h) + (rows + 1) * g, config.background);
  if (!config.title.empty()) c.text(g, g + config.title_size, config.title, title);
  for (int i = 0; i < n; ++i) {
    const int col = i % cols, row = i / cols;
    const int x = g + col * (cell_w + g), y = top + g + row * (cell_h + title_h + g);
    c.text(x + cell_w / 2.0, y + config.panel_title_size, panels[i].title, panel_title);
    const int ix = x + (cell_w - panels[i].image.width) / 2;
    c.image(panels[i].image, ix, y + title_h);
    c.strokeRect(ix - 0.5, y + title_h - 0.5, panels[i].image.width + 1, panels[i].image.height + 1, {200, 200, 200});
  }
  return c.toImage();
}

Image renderMapMontage(const std::vector<MapPanel>& panels, const ClassTable& table, TopDownConfig config,
                       const MontageConfig& montage) {
  if (panels.empty()) fail("map montage", "no panels");
  static const LabeledCloud kEmpty;
  if (!config.view) {
    std::optional<ViewBox> all;
    for (const auto& p : panels) {
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
  for (const auto& p : panels)
    rendered.push_back({p.title, renderTopDown(p.map ? *p.map : kEmpty, table, p.trajectory, p.hazards, config)});
  return renderMontage(rendered, montage);
}

}  // namespace hazmap
