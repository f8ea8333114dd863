// sensor_msgs/CompressedImage → property image: PNG (8- or 16-bit; 16-bit keeps its counts) and
// JPEG (8-bit; colour stands in through its luminance), decoded with stb_image.
#include <stb/stb_image.h>

#include <cmath>
#include <limits>
#include <memory>

#include "hazmap/core/error.hpp"
#include "hazmap/properties/property_image.hpp"

namespace hazmap {

namespace {

struct StbFree {
  void operator()(void* p) const { stbi_image_free(p); }
};

bool hasPrefix(const std::vector<std::uint8_t>& d, std::initializer_list<std::uint8_t> magic) {
  if (d.size() < magic.size()) return false;
  std::size_t i = 0;
  for (std::uint8_t b : magic)
    if (d[i++] != b) return false;
  return true;
}

/// "png" or "jpeg" from the bytes, after checking the message's `format` does not say otherwise
/// (image_transport writes "png", "jpeg", "mono16; png compressed", "bgr8; jpeg compressed bgr8").
std::string containerOf(const CompressedImageMsg& msg, const std::string& where) {
  const std::string& f = msg.format;
  if (f.find("compressedDepth") != std::string::npos)
    fail(where, "compressed image format '" + f + "' is not supported (png, jpeg)");
  const bool png = hasPrefix(msg.data, {0x89, 'P', 'N', 'G'});
  const bool jpeg = hasPrefix(msg.data, {0xFF, 0xD8, 0xFF});
  const bool says_png = f.find("png") != std::string::npos;
  const bool says_jpeg = f.find("jpeg") != std::string::npos || f.find("jpg") != std::string::npos;
  if (!f.empty() && !says_png && !says_jpeg)
    fail(where, "compressed image format '" + f + "' is not supported (png, jpeg)");
  if ((says_png && !png) || (says_jpeg && !jpeg) || (!png && !jpeg))
    fail(where, "compressed image data is not " + (f.empty() ? std::string("a PNG or JPEG") : "'" + f + "'") + " file");
  return png ? "png" : "jpeg";
}

}  // namespace

PropertyImage imageFromCompressed(const CompressedImageMsg& msg, const CameraCalibration& camera,
                                  const std::string& where) {
  containerOf(msg, where);
  if (msg.data.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) fail(where, "compressed image too large");
  const int n = static_cast<int>(msg.data.size());
  int w = 0, h = 0, comp = 0;
  if (!stbi_info_from_memory(msg.data.data(), n, &w, &h, &comp))
    fail(where, std::string("cannot read compressed image (") + stbi_failure_reason() + ")");
  if (w != camera.model.width() || h != camera.model.height())
    fail(where, "image is " + std::to_string(w) + "x" + std::to_string(h) + " but camera '" + camera.name +
                    "' is calibrated for " + std::to_string(camera.model.width()) + "x" +
                    std::to_string(camera.model.height()));
  PropertyImage img;
  img.width = w;
  img.height = h;
  img.stamp = msg.header.stamp;
  img.values.resize(static_cast<std::size_t>(w) * h);
  const PropertyChannel& ch = camera.channel;
  const bool colour = comp >= 3;
  if (stbi_is_16_bit_from_memory(msg.data.data(), n) && !colour) {
    std::unique_ptr<stbi_us, StbFree> data(stbi_load_16_from_memory(msg.data.data(), n, &w, &h, &comp, 1));
    if (!data) fail(where, std::string("cannot decode compressed image (") + stbi_failure_reason() + ")");
    for (std::size_t i = 0; i < img.values.size(); ++i) img.values[i] = static_cast<float>(data.get()[i] * ch.scale + ch.offset);
    return img;
  }
  // 8-bit (a 16-bit colour PNG is read as 8-bit colour): counts 0..255, colour as luminance.
  std::unique_ptr<stbi_uc, StbFree> data(stbi_load_from_memory(msg.data.data(), n, &w, &h, &comp, colour ? 3 : 1));
  if (!data) fail(where, std::string("cannot decode compressed image (") + stbi_failure_reason() + ")");
  const stbi_uc* p = data.get();
  for (std::size_t i = 0; i < img.values.size(); ++i) {
    const double raw = colour ? 0.299 * p[3 * i] + 0.587 * p[3 * i + 1] + 0.114 * p[3 * i + 2] : double(p[i]);
    img.values[i] = static_cast<float>(raw * ch.scale + ch.offset);
  }
  return img;
}

}  // namespace hazmap
