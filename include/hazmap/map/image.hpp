#pragma once
// A small RGB raster with the few drawing operations the map renders need (points, lines,
// circles, rectangles, text with a built-in bitmap font), and an atomic PNG writer (stb).
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/core/class_table.hpp"  // Rgb

namespace hazmap {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< row-major, 3 bytes per pixel, top row first

  Image() = default;
  Image(int w, int h, Rgb fill = {255, 255, 255});
  bool empty() const { return width <= 0 || height <= 0; }
  bool inside(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  /// Out-of-bounds writes are ignored, reads return black.
  void set(int x, int y, Rgb c);
  Rgb get(int x, int y) const;
  /// c·alpha + old·(1 − alpha), alpha in [0, 1].
  void blend(int x, int y, Rgb c, float alpha);
};

/// Fills [x0, x1) × [y0, y1) (clipped).
void fillRect(Image& img, int x0, int y0, int x1, int y1, Rgb c);
/// Rectangle outline, `thickness` pixels inwards.
void drawRect(Image& img, int x0, int y0, int x1, int y1, Rgb c, int thickness = 1);
/// Line between pixel-centre coordinates, `thickness` pixels wide.
void drawLine(Image& img, double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);
void fillCircle(Image& img, double cx, double cy, double radius, Rgb c);
void drawCircle(Image& img, double cx, double cy, double radius, Rgb c, int thickness = 1);

/// Text with stb_easy_font's built-in bitmap font (ASCII), each font pixel drawn as a
/// scale×scale block; (x, y) is the top-left corner. '\n' starts a new line.
void drawText(Image& img, int x, int y, const std::string& text, Rgb c, int scale = 1);
int textWidth(const std::string& text, int scale = 1);
int textHeight(const std::string& text, int scale = 1);

/// Copies `src` into `dst` with its top-left corner at (x, y) (clipped).
void blit(Image& dst, const Image& src, int x, int y);

/// PNG bytes of the image. Throws hazmap::Error on an empty image.
std::vector<std::uint8_t> encodePng(const Image& img);
/// Writes a PNG atomically (never a half-written file). Throws hazmap::Error naming the path.
void writePng(const std::filesystem::path& path, const Image& img);

}  // namespace hazmap
