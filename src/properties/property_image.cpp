#include "hazmap/properties/property_image.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <sstream>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"

namespace hazmap {

namespace fs = std::filesystem;

PropertyImage toPropertyImage(const Gray16& raw, const PropertyChannel& channel, double stamp) {
  PropertyImage img;
  img.width = raw.width;
  img.height = raw.height;
  img.stamp = stamp;
  img.values.resize(raw.pixels.size());
  const double scale = channel.scale, offset = channel.offset;
  for (std::size_t i = 0; i < raw.pixels.size(); ++i)
    img.values[i] = static_cast<float>(raw.pixels[i] * scale + offset);
  return img;
}

namespace {

void checkSize(int width, int height, const CameraCalibration& camera, const std::string& where) {
  if (width != camera.model.width() || height != camera.model.height())
    fail(where, "image is " + std::to_string(width) + "x" + std::to_string(height) + " but camera '" + camera.name +
                    "' is calibrated for " + std::to_string(camera.model.width()) + "x" +
                    std::to_string(camera.model.height()));
}

template <typename Raw>
Raw sampleAt(const std::uint8_t* p, bool big_endian) {
  std::uint8_t b[sizeof(Raw)];
  std::memcpy(b, p, sizeof(Raw));
  const bool host_big = std::endian::native == std::endian::big;
  if (big_endian != host_big) std::reverse(b, b + sizeof(Raw));
  Raw v;
  std::memcpy(&v, b, sizeof(Raw));
  return v;
}

}  // namespace

PropertyImage imageFromMessage(const ImageMsg& msg, const CameraCalibration& camera, const std::string& where) {
  checkSize(static_cast<int>(msg.width), static_cast<int>(msg.height), camera, where);
  int bytes = 0;
  const std::string& e = msg.encoding;
  if (e == "mono16" || e == "16UC1") bytes = 2;
  else if (e == "mono8" || e == "8UC1") bytes = 1;
  else if (e == "32FC1") bytes = 4;
  else fail(where, "image encoding '" + e + "' is not supported (mono16, 16UC1, mono8, 8UC1, 32FC1)");
  const std::size_t row = static_cast<std::size_t>(msg.width) * bytes;
  if (msg.step < row) fail(where, "image step " + std::to_string(msg.step) + " is shorter than a row");
  if (msg.data.size() < static_cast<std::size_t>(msg.step) * (msg.height - 1) + row || msg.height == 0)
    fail(where, "image data has " + std::to_string(msg.data.size()) + " bytes, step·height needs " +
                    std::to_string(static_cast<std::size_t>(msg.step) * msg.height));
  PropertyImage img;
  img.width = static_cast<int>(msg.width);
  img.height = static_cast<int>(msg.height);
  img.stamp = msg.header.stamp;
  img.values.resize(static_cast<std::size_t>(img.width) * img.height);
  const PropertyChannel& ch = camera.channel;
  for (std::uint32_t y = 0; y < msg.height; ++y) {
    const std::uint8_t* r = msg.data.data() + static_cast<std::size_t>(y) * msg.step;
    float* out = img.values.data() + static_cast<std::size_t>(y) * msg.width;
    for (std::uint32_t x = 0; x < msg.width; ++x) {
      if (bytes == 4) {
        const float v = sampleAt<float>(r + 4 * x, msg.is_bigendian);
        out[x] = std::isfinite(v) ? static_cast<float>(v + ch.float_offset) : NAN;
      } else if (bytes == 2) {
        out[x] = static_cast<float>(sampleAt<std::uint16_t>(r + 2 * x, msg.is_bigendian) * ch.scale + ch.offset);
      } else {
        out[x] = static_cast<float>(r[x] * ch.scale + ch.offset);
      }
    }
  }
  return img;
}

ImageFolder::ImageFolder(const fs::path& dir) : dir_(dir) {
  const std::string where = dir.string();
  if (!fs::is_directory(dir)) fail(where, "image folder does not exist");
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string ext = entry.path().extension().string();
    if (entry.is_regular_file() && (ext == ".png" || ext == ".tif" || ext == ".tiff"))
      files_.push_back(entry.path());
  }
  std::sort(files_.begin(), files_.end());
  if (files_.empty()) fail(where, "no .png/.tif images in the folder");
  std::istringstream times(readTextFile(dir / "times.txt"));
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(times, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    try {
      std::size_t used = 0;
      const double t = std::stod(line, &used);
      if (!std::isfinite(t) || line.find_first_not_of(" \t\r", used) != std::string::npos) throw std::invalid_argument("");
      if (!stamps_.empty() && t < stamps_.back())
        fail((dir / "times.txt").string(), "line " + std::to_string(line_no) + ": stamps go back in time");
      stamps_.push_back(t);
    } catch (const std::logic_error&) {
      fail((dir / "times.txt").string(), "line " + std::to_string(line_no) + ": not a number");
    }
  }
  if (stamps_.size() != files_.size())
    fail((dir / "times.txt").string(), "has " + std::to_string(stamps_.size()) + " stamps for " +
                                           std::to_string(files_.size()) + " images");
}

PropertyImage ImageFolder::load(std::size_t i, const CameraCalibration& camera) const {
  const Gray16 raw = readGray16(files_.at(i));
  checkSize(raw.width, raw.height, camera, files_[i].string());
  return toPropertyImage(raw, camera.channel, stamps_[i]);
}

}  // namespace hazmap
