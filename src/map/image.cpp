#include "hazmap/map/image.hpp"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

Image::Image(int w, int h, Rgb fill) : width(std::max(0, w)), height(std::max(0, h)) {
  rgb.resize(std::size_t(width) * std::size_t(height) * 3);
  for (std::size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = fill[0];
    rgb[i + 1] = fill[1];
    rgb[i + 2] = fill[2];
  }
}

void Image::set(int x, int y, Rgb c) {
  if (!inside(x, y)) return;
  std::uint8_t* p = &rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3];
  p[0] = c[0];
  p[1] = c[1];
  p[2] = c[2];
}

Rgb Image::get(int x, int y) const {
  if (!inside(x, y)) return {0, 0, 0};
  const std::uint8_t* p = &rgb[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3];
  return {p[0], p[1], p[2]};
}

void Image::blend(int x, int y, Rgb c, float alpha) {
  if (!inside(x, y)) return;
  alpha = std::clamp(alpha, 0.0f, 1.0f);
  const Rgb o = get(x, y);
  Rgb n;
  for (int k = 0; k < 3; ++k) n[k] = std::uint8_t(std::lround(c[k] * alpha + o[k] * (1.0f - alpha)));
  set(x, y, n);
}

void blit(Image& dst, const Image& src, int x, int y) {
  for (int sy = 0; sy < src.height; ++sy) {
    const int dy = y + sy;
    if (dy < 0 || dy >= dst.height) continue;
    for (int sx = 0; sx < src.width; ++sx) dst.set(x + sx, dy, src.get(sx, sy));
  }
}

std::vector<std::uint8_t> encodePng(const Image& img) {
  if (img.empty() || img.rgb.size() != std::size_t(img.width) * std::size_t(img.height) * 3)
    fail("png", "image is empty or inconsistent");
  std::vector<std::uint8_t> out;
  const auto sink = [](void* ctx, void* data, int size) {
    auto* v = static_cast<std::vector<std::uint8_t>*>(ctx);
    const auto* bytes = static_cast<const std::uint8_t*>(data);
    v->insert(v->end(), bytes, bytes + size);
  };
  if (!stbi_write_png_to_func(sink, &out, img.width, img.height, 3, img.rgb.data(), img.width * 3))
    fail("png", "encoding failed");
  return out;
}

void writePng(const std::filesystem::path& path, const Image& img) {
  if (img.empty()) fail(path.string(), "cannot write an empty image");
  const std::vector<std::uint8_t> bytes = encodePng(img);
  writeFileAtomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  });
}

}  // namespace hazmap
