#pragma once
// A line plot over named categories (a sweep's settings along x) with an optional logarithmic y
// axis: one line with markers per series, a legend, Cairo-drawn like the other figures.
#include <string>
#include <vector>

#include "hazmap/map/image.hpp"

namespace hazmap {

struct CategorySeries {
  std::string label;
  std::vector<double> values;  ///< one per category; NaN or (log axis) <= 0 = no point
  Rgb color{0, 0, 0};
};

struct CategoryPlotConfig {
  int width = 620, height = 440;
  std::string title;
  std::string x_label, y_label;
  std::vector<std::string> categories;  ///< tick labels along x, in order
  bool log_y = true;
};

/// Throws hazmap::Error on no categories, a series whose value count differs, or an image too
/// small to draw.
Image renderCategoryPlot(const std::vector<CategorySeries>& series, const CategoryPlotConfig& config);

}  // namespace hazmap
