#pragma once
// Cairo drawing for the PNG figures: anti-aliased lines, circles and rectangles, and real text
// (DejaVu Sans from fonts-dejavu-core), on an RGB image. Private to src/map.
#include <cairo.h>

#include <string>
#include <vector>

#include "hazmap/map/image.hpp"

namespace hazmap::figure {

enum class Align { Left, Center, Right };

// The figures' shared colours: one place, so the trajectory plot, the map render, the montage
// and the legends agree.
inline constexpr Rgb kBlack{0, 0, 0};
inline constexpr Rgb kWhite{255, 255, 255};
inline constexpr Rgb kText{30, 30, 30};  ///< titles, labels and legend text

struct TextStyle {
  double size = 13.0;  ///< font size in pixels
  Rgb color{0, 0, 0};
  bool bold = false;
  Align align = Align::Left;
};

class Canvas {
 public:
  Canvas(int width, int height, Rgb background = {255, 255, 255});
  ~Canvas();
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  cairo_t* cr() { return cr_; }

  void fillRect(double x, double y, double w, double h, Rgb c, double alpha = 1.0);
  void strokeRect(double x, double y, double w, double h, Rgb c, double line_width = 1.0);
  void line(double x0, double y0, double x1, double y1, Rgb c, double line_width = 1.0);
  /// A polyline (round joins and caps); points with a NaN split it.
  void polyline(const std::vector<std::pair<double, double>>& points, Rgb c, double line_width = 2.0);
  void fillCircle(double cx, double cy, double r, Rgb c);
  void strokeCircle(double cx, double cy, double r, Rgb c, double line_width = 1.0);
  /// Text whose baseline starts (Left), is centred (Center) or ends (Right) at (x, y).
  void text(double x, double y, const std::string& s, const TextStyle& style = {});
  /// Text rotated 90° counter-clockwise, centred on (x, y) (y-axis labels).
  void verticalText(double x, double y, const std::string& s, const TextStyle& style = {});
  double textWidth(const std::string& s, const TextStyle& style = {});
  /// Copies an image in with its top-left corner at (x, y).
  void image(const Image& img, double x, double y);
  /// Direct pixel access to the surface (for the per-pixel height shading): 0xAARRGGBB.
  std::uint32_t* pixels();
  int stride() const;  ///< in pixels
  void markDirty();    ///< after writing pixels()

  Image toImage();

 private:
  void setColor(Rgb c, double alpha = 1.0);
  void setFont(const TextStyle& style);
  int width_, height_;
  cairo_surface_t* surface_ = nullptr;
  cairo_t* cr_ = nullptr;
};

/// 1, 2 or 5 × 10^k, the smallest at least range / target.
double niceStep(double range, double target);
/// "%g" without "-0".
std::string formatNumber(double v);

/// A box of (colour swatch, label) entries; top-right corner at (x, top), or top-left with
/// anchor_left.
struct LegendEntry {
  Rgb color;
  std::string label;
  bool line = false;  ///< a line swatch instead of a filled square
};
void drawLegend(Canvas& canvas, double x, double top, const std::vector<LegendEntry>& entries,
                double font_size = 13.0, bool anchor_left = false);
/// Scale bar of `metres` at `pixels_per_metre`, left end at (x, y) (bar's baseline).
void drawScaleBar(Canvas& canvas, double x, double y, double metres, double pixels_per_metre);

}  // namespace hazmap::figure
