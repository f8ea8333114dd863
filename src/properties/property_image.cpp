#include "hazmap/properties/property_image.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <optional>
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

namespace {

enum class SampleType { U8, U16, S16, F32, F64 };

/// How a sensor_msgs/Image encoding is laid out: sample type and channels (3–4 = colour,
/// turned into luminance; `bgr` = blue first).
struct EncodingLayout {
  SampleType type = SampleType::U8;
  int channels = 1;
  bool bgr = false;
  int sampleBytes() const {
    switch (type) {
      case SampleType::U8: return 1;
      case SampleType::U16: case SampleType::S16: return 2;
      case SampleType::F32: return 4;
      case SampleType::F64: return 8;
    }
    return 1;
  }
  bool floating() const { return type == SampleType::F32 || type == SampleType::F64; }
};

constexpr const char* kEncodings = "mono16, 16UC1, 16SC1, mono8, 8UC1, 32FC1, 64FC1, rgb8, bgr8, rgba8, bgra8";

std::optional<EncodingLayout> layoutOf(const std::string& e) {
  if (e == "mono16" || e == "16UC1") return EncodingLayout{SampleType::U16};
  if (e == "16SC1") return EncodingLayout{SampleType::S16};
  if (e == "mono8" || e == "8UC1") return EncodingLayout{SampleType::U8};
  if (e == "32FC1") return EncodingLayout{SampleType::F32};
  if (e == "64FC1") return EncodingLayout{SampleType::F64};
  if (e == "rgb8" || e == "8UC3") return EncodingLayout{SampleType::U8, 3};
  if (e == "bgr8") return EncodingLayout{SampleType::U8, 3, true};
  if (e == "rgba8" || e == "8UC4") return EncodingLayout{SampleType::U8, 4};
  if (e == "bgra8") return EncodingLayout{SampleType::U8, 4, true};
  return std::nullopt;
}

/// One pixel in the channel's units: integers through scale and offset, floats through
/// float_offset, colour through its Rec. 601 luminance (0..255) as an 8-bit value.
float pixelValue(const std::uint8_t* p, const EncodingLayout& l, bool big_endian, const PropertyChannel& ch) {
  double raw = 0.0;
  if (l.channels >= 3) {
    const double r = p[l.bgr ? 2 : 0], g = p[1], b = p[l.bgr ? 0 : 2];
    raw = 0.299 * r + 0.587 * g + 0.114 * b;
  } else {
    switch (l.type) {
      case SampleType::U8: raw = p[0]; break;
      case SampleType::U16: raw = sampleAt<std::uint16_t>(p, big_endian); break;
      case SampleType::S16: raw = sampleAt<std::int16_t>(p, big_endian); break;
      case SampleType::F32: raw = sampleAt<float>(p, big_endian); break;
      case SampleType::F64: raw = sampleAt<double>(p, big_endian); break;
    }
  }
  if (l.floating()) return std::isfinite(raw) ? static_cast<float>(raw + ch.float_offset) : NAN;
  return static_cast<float>(raw * ch.scale + ch.offset);
}

}  // namespace

PropertyImage imageFromMessage(const ImageMsg& msg, const CameraCalibration& camera, const std::string& where) {
  const std::optional<EncodingLayout> layout = layoutOf(msg.encoding);
  if (!layout)
    fail(where, "image encoding '" + msg.encoding + "' is not supported (" + kEncodings + ")");
  checkSize(static_cast<int>(msg.width), static_cast<int>(msg.height), camera, where);
  const std::size_t pixel = static_cast<std::size_t>(layout->sampleBytes()) * layout->channels;
  const std::size_t row = static_cast<std::size_t>(msg.width) * pixel;
  if (msg.step < row) fail(where, "image step " + std::to_string(msg.step) + " is shorter than a row");
  if (msg.height == 0 || msg.data.size() < static_cast<std::size_t>(msg.step) * (msg.height - 1) + row)
    fail(where, "image data has " + std::to_string(msg.data.size()) + " bytes, step·height needs " +
                    std::to_string(static_cast<std::size_t>(msg.step) * msg.height));
  PropertyImage img;
  img.width = static_cast<int>(msg.width);
  img.height = static_cast<int>(msg.height);
  img.stamp = msg.header.stamp;
  img.values.resize(static_cast<std::size_t>(img.width) * img.height);
  for (std::uint32_t y = 0; y < msg.height; ++y) {
    const std::uint8_t* r = msg.data.data() + static_cast<std::size_t>(y) * msg.step;
    float* out = img.values.data() + static_cast<std::size_t>(y) * msg.width;
    for (std::uint32_t x = 0; x < msg.width; ++x) out[x] = pixelValue(r + pixel * x, *layout, msg.is_bigendian, camera.channel);
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
