// Baseline TIFF reader for what radiometric cameras export: one uncompressed grayscale image,
// 8 or 16 bits per sample, unsigned, in strips, either byte order. Anything else is rejected
// with a message; no TIFF library is linked for this.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "hazmap/core/error.hpp"
#include "hazmap/properties/property_image.hpp"

namespace hazmap {

namespace {

struct TiffBytes {
  const std::vector<std::uint8_t>& b;
  bool big_endian;
  const std::string& where;

  std::uint32_t read(std::size_t offset, int size) const {
    if (offset + size > b.size()) fail(where, "TIFF is truncated (offset " + std::to_string(offset) + ")");
    std::uint32_t v = 0;
    for (int i = 0; i < size; ++i) {
      const std::uint32_t byte = b[offset + i];
      v |= big_endian ? byte << (8 * (size - 1 - i)) : byte << (8 * i);
    }
    return v;
  }
};

/// The values of one IFD entry (SHORT or LONG, inline or at an offset).
std::vector<std::uint32_t> tagValues(const TiffBytes& t, std::size_t entry) {
  const std::uint32_t type = t.read(entry + 2, 2), count = t.read(entry + 4, 4);
  const int size = type == 3 ? 2 : type == 4 ? 4 : type == 1 ? 1 : 0;
  if (size == 0) return {};
  if (count > (1u << 24)) fail(t.where, "TIFF tag count " + std::to_string(count) + " is implausible");
  std::size_t at = entry + 8;
  if (static_cast<std::size_t>(size) * count > 4) at = t.read(entry + 8, 4);
  std::vector<std::uint32_t> values(count);
  for (std::uint32_t i = 0; i < count; ++i) values[i] = t.read(at + i * size, size);
  return values;
}

}  // namespace

Gray16 readTiff16(const std::vector<std::uint8_t>& bytes, const std::string& where) {
  const TiffBytes t{bytes, bytes.size() > 1 && bytes[0] == 'M', where};
  if (t.read(2, 2) != 42) fail(where, "not a TIFF file (bad magic number; BigTIFF is not supported)");
  const std::size_t ifd = t.read(4, 4);
  const std::uint32_t entries = t.read(ifd, 2);
  std::map<std::uint32_t, std::vector<std::uint32_t>> tags;
  for (std::uint32_t i = 0; i < entries; ++i) {
    const std::size_t e = ifd + 2 + 12 * static_cast<std::size_t>(i);
    tags[t.read(e, 2)] = tagValues(t, e);
  }
  const auto one = [&](std::uint32_t tag, std::uint32_t fallback, const char* name) {
    const auto it = tags.find(tag);
    if (it == tags.end() || it->second.empty()) {
      if (fallback == ~0u) fail(where, std::string("TIFF has no ") + name + " tag");
      return fallback;
    }
    return it->second[0];
  };
  Gray16 out;
  out.width = static_cast<int>(one(256, ~0u, "ImageWidth"));
  out.height = static_cast<int>(one(257, ~0u, "ImageLength"));
  const std::uint32_t bits = one(258, 1, "BitsPerSample");
  if (one(259, 1, "Compression") != 1) fail(where, "compressed TIFF is not supported (only uncompressed)");
  if (one(277, 1, "SamplesPerPixel") != 1) fail(where, "TIFF is not single-channel grayscale");
  if (one(339, 1, "SampleFormat") != 1) fail(where, "TIFF samples are not unsigned integers");
  if (one(262, 1, "PhotometricInterpretation") > 1) fail(where, "TIFF is not grayscale");
  if (bits != 8 && bits != 16) fail(where, "TIFF has " + std::to_string(bits) + " bits per sample (8 or 16 supported)");
  if (out.width <= 0 || out.height <= 0 || out.width > 65535 || out.height > 65535)
    fail(where, "TIFF image size is invalid");
  const auto offsets = tags[273], counts = tags[279];
  if (offsets.empty() || offsets.size() != counts.size()) fail(where, "TIFF strip offsets/byte counts are missing or differ");
  const int bytes_per_sample = static_cast<int>(bits / 8);
  out.pixels.resize(static_cast<std::size_t>(out.width) * out.height);
  std::size_t pixel = 0;
  for (std::size_t s = 0; s < offsets.size() && pixel < out.pixels.size(); ++s)
    for (std::size_t k = 0; k + bytes_per_sample <= counts[s] && pixel < out.pixels.size(); k += bytes_per_sample)
      out.pixels[pixel++] = static_cast<std::uint16_t>(t.read(offsets[s] + k, bytes_per_sample));
  if (pixel != out.pixels.size())
    fail(where, "TIFF strips hold " + std::to_string(pixel) + " pixels, the image needs " +
                    std::to_string(out.pixels.size()));
  return out;
}

}  // namespace hazmap
