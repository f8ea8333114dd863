#include "canvas.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "hazmap/core/error.hpp"

namespace hazmap::figure {

Canvas::Canvas(int width, int height, Rgb background) : width_(width), height_(height) {
  if (width <= 0 || height <= 0 || width > 20000 || height > 20000)
    fail("figure", "impossible image size " + std::to_string(width) + "x" + std::to_string(height));
  surface_ = cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height);
  cr_ = cairo_create(surface_);
  if (cairo_status(cr_) != CAIRO_STATUS_SUCCESS) fail("figure", "cairo could not create the image");
  fillRect(0, 0, width, height, background);
}

Canvas::~Canvas() {
  cairo_destroy(cr_);
  cairo_surface_destroy(surface_);
}

void Canvas::setColor(Rgb c, double alpha) {
  cairo_set_source_rgba(cr_, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, alpha);
}

void Canvas::fillRect(double x, double y, double w, double h, Rgb c, double alpha) {
  setColor(c, alpha);
  cairo_rectangle(cr_, x, y, w, h);
  cairo_fill(cr_);
}

void Canvas::strokeRect(double x, double y, double w, double h, Rgb c, double line_width) {
  setColor(c);
  cairo_set_line_width(cr_, line_width);
  cairo_rectangle(cr_, x, y, w, h);
  cairo_stroke(cr_);
}

void Canvas::line(double x0, double y0, double x1, double y1, Rgb c, double line_width) {
  polyline({{x0, y0}, {x1, y1}}, c, line_width);
}

void Canvas::polyline(const std::vector<std::pair<double, double>>& points, Rgb c, double line_width) {
  setColor(c);
  cairo_set_line_width(cr_, line_width);
  cairo_set_line_join(cr_, CAIRO_LINE_JOIN_ROUND);
  cairo_set_line_cap(cr_, CAIRO_LINE_CAP_ROUND);
  bool open = false;
  // Far-away coordinates (a diverged estimate) would overflow cairo's fixed point.
  const double limit = 1e6;
  for (const auto& [x, y] : points) {
    if (!std::isfinite(x) || !std::isfinite(y) || std::abs(x) > limit || std::abs(y) > limit) {
      open = false;
      continue;
    }
    if (open) cairo_line_to(cr_, x, y);
    else cairo_move_to(cr_, x, y);
    open = true;
  }
  cairo_stroke(cr_);
}

void Canvas::fillCircle(double cx, double cy, double r, Rgb c) {
  if (!std::isfinite(cx) || !std::isfinite(cy)) return;
  setColor(c);
  cairo_new_sub_path(cr_);
  cairo_arc(cr_, cx, cy, r, 0, 2 * M_PI);
  cairo_fill(cr_);
}

void Canvas::strokeCircle(double cx, double cy, double r, Rgb c, double line_width) {
  if (!std::isfinite(cx) || !std::isfinite(cy)) return;
  setColor(c);
  cairo_set_line_width(cr_, line_width);
  cairo_new_sub_path(cr_);
  cairo_arc(cr_, cx, cy, r, 0, 2 * M_PI);
  cairo_stroke(cr_);
}

void Canvas::setFont(const TextStyle& style) {
  cairo_select_font_face(cr_, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         style.bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr_, style.size);
}

double Canvas::textWidth(const std::string& s, const TextStyle& style) {
  setFont(style);
  cairo_text_extents_t e;
  cairo_text_extents(cr_, s.c_str(), &e);
  return e.x_advance;
}

void Canvas::text(double x, double y, const std::string& s, const TextStyle& style) {
  const double w = textWidth(s, style);
  const double x0 = style.align == Align::Left ? x : style.align == Align::Center ? x - w / 2 : x - w;
  setColor(style.color);
  cairo_move_to(cr_, std::round(x0), std::round(y));
  cairo_show_text(cr_, s.c_str());
}

void Canvas::verticalText(double x, double y, const std::string& s, const TextStyle& style) {
  cairo_save(cr_);
  cairo_translate(cr_, x, y);
  cairo_rotate(cr_, -M_PI / 2);
  TextStyle centred = style;
  centred.align = Align::Center;
  text(0, 0, s, centred);
  cairo_restore(cr_);
}

void Canvas::image(const Image& img, double x, double y) {
  if (img.empty()) return;
  cairo_surface_t* src = cairo_image_surface_create(CAIRO_FORMAT_RGB24, img.width, img.height);
  cairo_surface_flush(src);
  auto* data = reinterpret_cast<std::uint32_t*>(cairo_image_surface_get_data(src));
  const int stride = cairo_image_surface_get_stride(src) / 4;
  for (int r = 0; r < img.height; ++r)
    for (int c = 0; c < img.width; ++c) {
      const Rgb p = img.get(c, r);
      data[r * stride + c] = 0xff000000u | std::uint32_t(p[0]) << 16 | std::uint32_t(p[1]) << 8 | p[2];
    }
  cairo_surface_mark_dirty(src);
  cairo_set_source_surface(cr_, src, std::round(x), std::round(y));
  cairo_paint(cr_);
  cairo_surface_destroy(src);
}

std::uint32_t* Canvas::pixels() {
  cairo_surface_flush(surface_);
  return reinterpret_cast<std::uint32_t*>(cairo_image_surface_get_data(surface_));
}

int Canvas::stride() const { return cairo_image_surface_get_stride(surface_) / 4; }

void Canvas::markDirty() { cairo_surface_mark_dirty(surface_); }

Image Canvas::toImage() {
  const std::uint32_t* data = pixels();
  Image img(width_, height_);
  for (int r = 0; r < height_; ++r)
    for (int c = 0; c < width_; ++c) {
      const std::uint32_t p = data[r * stride() + c];
      img.set(c, r, {std::uint8_t(p >> 16), std::uint8_t(p >> 8), std::uint8_t(p)});
    }
  return img;
}

double niceStep(double range, double target) {
  if (!(range > 0) || !std::isfinite(range)) return 1.0;
  const double raw = range / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double norm = raw / mag;
  return (norm <= 1.0 ? 1.0 : norm <= 2.0 ? 2.0 : norm <= 5.0 ? 5.0 : 10.0) * mag;
}

std::string formatNumber(double v) {
  if (std::abs(v) < 1e-9) v = 0.0;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

void drawLegend(Canvas& canvas, double x, double top, const std::vector<LegendEntry>& entries,
                double font_size, bool anchor_left) {
  if (entries.empty()) return;
  const TextStyle style{font_size, {20, 20, 20}};
  const double line_h = font_size * 1.5, swatch = font_size * 1.6;
  double w = 0;
  for (const auto& e : entries) w = std::max(w, canvas.textWidth(e.label, style));
  const double box_w = w + swatch + 24, box_h = double(entries.size()) * line_h + 10;
  const double x0 = std::round(anchor_left ? x : x - box_w) + 0.5, y0 = std::round(top) + 0.5;
  canvas.fillRect(x0, y0, box_w, box_h, {255, 255, 255}, 0.9);
  canvas.strokeRect(x0, y0, box_w, box_h, {150, 150, 150});
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const double cy = y0 + 5 + (double(i) + 0.5) * line_h;
    if (entries[i].line)
      canvas.line(x0 + 8, cy, x0 + 8 + swatch, cy, entries[i].color, 3.0);
    else
      canvas.fillRect(x0 + 8, cy - font_size * 0.4, swatch, font_size * 0.8, entries[i].color);
    canvas.text(x0 + 16 + swatch, cy + font_size * 0.35, entries[i].label, style);
  }
}

void drawScaleBar(Canvas& canvas, double x, double y, double metres, double pixels_per_metre) {
  const double w = metres * pixels_per_metre;
  canvas.fillRect(x, y - 6, w / 2, 6, kBlack);
  canvas.fillRect(x + w / 2, y - 6, w / 2, 6, kWhite);
  canvas.strokeRect(x, y - 6, w, 6, kBlack, 1.0);
  const TextStyle style{12, {20, 20, 20}, false, Align::Center};
  canvas.text(x, y + 14, "0", style);
  canvas.text(x + w, y + 14, formatNumber(metres) + " m", style);
}

}  // namespace hazmap::figure
