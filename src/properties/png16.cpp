// 16-bit grayscale PNG writing (stb_image_write has no 16-bit PNG) and reading (stb_image).
#include <stb/stb_image.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "hazmap/properties/property_image.hpp"

// Exported by libstb (stb_image_write.c) but declared only with the implementation.
extern "C" unsigned char* stbi_zlib_compress(unsigned char* data, int data_len, int* out_len, int quality);

namespace hazmap {

Gray16 readTiff16(const std::vector<std::uint8_t>& bytes, const std::string& where);  // tiff16.cpp

namespace {

std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

void putBigEndian32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(v >> s));
}

void putChunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
  putBigEndian32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  putBigEndian32(out, crc32(out.data() + start, out.size() - start));
}

}  // namespace

std::vector<std::uint8_t> encodePng16(const Gray16& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * image.height)
    fail("png", "16-bit image has an inconsistent size");
  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> header;
  putBigEndian32(header, static_cast<std::uint32_t>(image.width));
  putBigEndian32(header, static_cast<std::uint32_t>(image.height));
  header.insert(header.end(), {16, 0, 0, 0, 0});  // 16 bits, grayscale, deflate, no filter, no interlace
  putChunk(out, "IHDR", header);
  // Scanlines with the "Up" filter (smooth images compress better), samples big-endian.
  const std::size_t row_bytes = 1 + 2 * static_cast<std::size_t>(image.width);
  std::vector<std::uint8_t> raw(row_bytes * image.height);
  for (int y = 0; y < image.height; ++y) {
    std::uint8_t* row = &raw[y * row_bytes];
    row[0] = y == 0 ? 0 : 2;
    for (int x = 0; x < image.width; ++x) {
      const std::uint16_t v = image.pixels[static_cast<std::size_t>(y) * image.width + x];
      const std::uint16_t above = y == 0 ? 0 : image.pixels[static_cast<std::size_t>(y - 1) * image.width + x];
      row[1 + 2 * x] = static_cast<std::uint8_t>((v >> 8) - (above >> 8));
      row[2 + 2 * x] = static_cast<std::uint8_t>((v & 0xFF) - (above & 0xFF));
    }
  }
  int compressed_size = 0;
  unsigned char* compressed = stbi_zlib_compress(raw.data(), static_cast<int>(raw.size()), &compressed_size, 6);
  if (!compressed) fail("png", "zlib compression failed");
  std::vector<std::uint8_t> idat(compressed, compressed + compressed_size);
  std::free(compressed);
  putChunk(out, "IDAT", idat);
  putChunk(out, "IEND", {});
  return out;
}

void writePng16(const std::filesystem::path& path, const Gray16& image) {
  const std::vector<std::uint8_t> bytes = encodePng16(image);
  writeFileAtomically(path, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  });
}

Gray16 readGray16(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path.string(), "cannot open image");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return decodeGray16(bytes, path.string());
}

Gray16 decodeGray16(const std::vector<std::uint8_t>& bytes, const std::string& where) {
  if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) fail(where, "image file too large");
  if (bytes.size() >= 4 && ((bytes[0] == 'I' && bytes[1] == 'I') || (bytes[0] == 'M' && bytes[1] == 'M')))
    return readTiff16(bytes, where);
  const int n = static_cast<int>(bytes.size());
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(bytes.data(), n, &w, &h, &channels))
    fail(where, std::string("not a readable PNG/TIFF image (") + stbi_failure_reason() + ")");
  if (channels != 1) fail(where, "image has " + std::to_string(channels) + " channels; expected one (grayscale)");
  Gray16 out;
  out.width = w;
  out.height = h;
  out.pixels.resize(static_cast<std::size_t>(w) * h);
  if (stbi_is_16_bit_from_memory(bytes.data(), n)) {
    stbi_us* data = stbi_load_16_from_memory(bytes.data(), n, &w, &h, &channels, 1);
    if (!data) fail(where, std::string("cannot decode image (") + stbi_failure_reason() + ")");
    std::memcpy(out.pixels.data(), data, out.pixels.size() * 2);
    stbi_image_free(data);
  } else {
    stbi_uc* data = stbi_load_from_memory(bytes.data(), n, &w, &h, &channels, 1);
    if (!data) fail(where, std::string("cannot decode image (") + stbi_failure_reason() + ")");
    for (std::size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = data[i];
    stbi_image_free(data);
  }
  return out;
}

}  // namespace hazmap
