#include "hazmap/map/image.hpp"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

// stb_easy_font: public-domain bitmap font; every function is static, so including it here
// keeps it private to this file.
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#endif
#include <stb/stb_easy_font.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

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

void fillRect(Image& img, int x0, int y0, int x1, int y1, Rgb c) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, img.width);
  y1 = std::min(y1, img.height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) img.set(x, y, c);
}

void drawRect(Image& img, int x0, int y0, int x1, int y1, Rgb c, int t) {
  fillRect(img, x0, y0, x1, y0 + t, c);
  fillRect(img, x0, y1 - t, x1, y1, c);
  fillRect(img, x0, y0, x0 + t, y1, c);
  fillRect(img, x1 - t, y0, x1, y1, c);
}

void fillCircle(Image& img, double cx, double cy, double r, Rgb c) {
  const int x0 = int(std::floor(cx - r)), x1 = int(std::ceil(cx + r));
  const int y0 = int(std::floor(cy - r)), y1 = int(std::ceil(cy + r));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x)
      if ((x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r) img.set(x, y, c);
}

void drawCircle(Image& img, double cx, double cy, double r, Rgb c, int t) {
  const double inner = std::max(0.0, r - t);
  const int x0 = int(std::floor(cx - r)), x1 = int(std::ceil(cx + r));
  const int y0 = int(std::floor(cy - r)), y1 = int(std::ceil(cy + r));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy);
      if (d2 <= r * r && d2 >= inner * inner) img.set(x, y, c);
    }
}

void drawLine(Image& img, double x0, double y0, double x1, double y1, Rgb c, int thickness) {
  if (!std::isfinite(x0) || !std::isfinite(y0) || !std::isfinite(x1) || !std::isfinite(y1)) return;
  // Clip crudely: lines far outside the image are skipped instead of walked pixel by pixel.
  const double lim = 4.0 * (img.width + img.height) + 100.0;
  if (std::abs(x0) > lim || std::abs(y0) > lim || std::abs(x1) > lim || std::abs(y1) > lim) return;
  const double len = std::hypot(x1 - x0, y1 - y0);
  const int steps = std::max(1, int(std::ceil(len * 2.0)));
  const double r = 0.5 * (thickness - 1);
  for (int s = 0; s <= steps; ++s) {
    const double t = double(s) / steps;
    const double x = x0 + t * (x1 - x0), y = y0 + t * (y1 - y0);
    if (thickness <= 1)
      img.set(int(std::lround(x)), int(std::lround(y)), c);
    else
      fillCircle(img, x, y, r + 0.25, c);
  }
}

namespace {
struct FontQuads {
  std::vector<float> x0, y0, x1, y1;
};
// Axis-aligned quads of the text in font units (1 unit = 1 pixel at scale 1).
FontQuads fontQuads(const std::string& text) {
  std::vector<char> buf(text.begin(), text.end());
  buf.push_back('\0');
  std::vector<char> vbuf(std::max<std::size_t>(4096, text.size() * 300));
  const int quads = stb_easy_font_print(0, 0, buf.data(), nullptr, vbuf.data(), int(vbuf.size()));
  FontQuads q;
  for (int i = 0; i < quads; ++i) {
    float v[4][4];  // 4 vertices × (x, y, z, rgba-as-float-bits)
    std::memcpy(v, vbuf.data() + std::size_t(i) * 64, 64);
    q.x0.push_back(std::min({v[0][0], v[1][0], v[2][0], v[3][0]}));
    q.x1.push_back(std::max({v[0][0], v[1][0], v[2][0], v[3][0]}));
    q.y0.push_back(std::min({v[0][1], v[1][1], v[2][1], v[3][1]}));
    q.y1.push_back(std::max({v[0][1], v[1][1], v[2][1], v[3][1]}));
  }
  return q;
}
}  // namespace

void drawText(Image& img, int x, int y, const std::string& text, Rgb c, int scale) {
  scale = std::max(1, scale);
  const FontQuads q = fontQuads(text);
  for (std::size_t i = 0; i < q.x0.size(); ++i)
    fillRect(img, x + int(std::lround(q.x0[i] * scale)), y + int(std::lround(q.y0[i] * scale)),
             x + int(std::lround(q.x1[i] * scale)), y + int(std::lround(q.y1[i] * scale)), c);
}

int textWidth(const std::string& text, int scale) {
  std::vector<char> buf(text.begin(), text.end());
  buf.push_back('\0');
  return stb_easy_font_width(buf.data()) * std::max(1, scale);
}

int textHeight(const std::string& text, int scale) {
  std::vector<char> buf(text.begin(), text.end());
  buf.push_back('\0');
  return stb_easy_font_height(buf.data()) * std::max(1, scale);
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
