#pragma once
// A small RGB raster (what the Cairo figures of render.hpp return) and an atomic PNG writer.
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

/// Copies `src` into `dst` with its top-left corner at (x, y) (clipped).
void blit(Image& dst, const Image& src, int x, int y);

/// PNG bytes of the image. Throws hazmap::Error on an empty image.
std::vector<std::uint8_t> encodePng(const Image& img);
/// Writes a PNG atomically (never a half-written file). Throws hazmap::Error naming the path.
void writePng(const std::filesystem::path& path, const Image& img);

}  // namespace hazmap
