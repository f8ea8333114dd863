#pragma once
// Property images: one float value per pixel in the channel's units (°C, reflectance, µSv/h),
// NaN where the camera gave nothing. Sources: a folder of 16-bit PNGs with times.txt (what
// `hazmap simulate --cameras` writes) and sensor_msgs/Image messages from bags.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "hazmap/properties/camera.hpp"
#include "hazmap/sources/ros_messages.hpp"

namespace hazmap {

struct PropertyImage {
  int width = 0, height = 0;
  double stamp = 0.0;         ///< s, the camera's clock (add CameraCalibration::time_offset)
  std::vector<float> values;  ///< row-major, width·height
  float at(int x, int y) const { return values[static_cast<std::size_t>(y) * width + x]; }
};

/// Raw 16-bit grayscale pixels (row-major).
struct Gray16 {
  int width = 0, height = 0;
  std::vector<std::uint16_t> pixels;
};

/// Writes a 16-bit grayscale PNG (atomically).
void writePng16(const std::filesystem::path& path, const Gray16& image);
/// PNG bytes of a 16-bit grayscale image.
std::vector<std::uint8_t> encodePng16(const Gray16& image);
/// Reads a 16-bit (or 8-bit: raw 0..255) grayscale PNG, or an uncompressed 8/16-bit
/// grayscale TIFF. Throws hazmap::Error naming the file for anything else.
Gray16 readGray16(const std::filesystem::path& path);
/// The same from bytes in memory (`where` names them in errors).
Gray16 decodeGray16(const std::vector<std::uint8_t>& bytes, const std::string& where);

/// Raw pixels → channel values (integer encoding: raw · scale + offset).
PropertyImage toPropertyImage(const Gray16& raw, const PropertyChannel& channel, double stamp);
/// A sensor_msgs/Image in the channel's units: mono16/16UC1/16SC1 and mono8/8UC1 through scale
/// and offset, 32FC1/64FC1 through float_offset, rgb8/bgr8/rgba8/bgra8 as their luminance
/// (0..255, Rec. 601) through scale and offset. Throws hazmap::Error naming `where` for an
/// unsupported encoding (naming it), a size other than the camera's, or a data length that
/// does not match step·height.
PropertyImage imageFromMessage(const ImageMsg& msg, const CameraCalibration& camera, const std::string& where);
/// A sensor_msgs/CompressedImage: PNG (16-bit grayscale keeps its counts, through scale and
/// offset like mono16; 8-bit like mono8) or JPEG (8-bit; colour as its luminance). Throws
/// naming `where` for another format (naming it), bytes that are not the format said, a
/// size other than the camera's.
PropertyImage imageFromCompressed(const CompressedImageMsg& msg, const CameraCalibration& camera,
                                  const std::string& where);

/// A folder of NNNNNN.png (or .tif/.tiff) with times.txt (one stamp per image, sorted by name).
class ImageFolder {
 public:
  /// Lists the images and reads times.txt; checks their counts agree and stamps increase.
  explicit ImageFolder(const std::filesystem::path& dir);
  std::size_t size() const { return files_.size(); }
  double stamp(std::size_t i) const { return stamps_.at(i); }
  const std::vector<double>& stamps() const { return stamps_; }
  /// Image i's file (its raw counts: readGray16).
  const std::filesystem::path& file(std::size_t i) const { return files_.at(i); }
  /// Loads image i in `camera`'s channel units; its size must be the camera's.
  PropertyImage load(std::size_t i, const CameraCalibration& camera) const;
  const std::filesystem::path& directory() const { return dir_; }

 private:
  std::filesystem::path dir_;
  std::vector<std::filesystem::path> files_;
  std::vector<double> stamps_;
};

}  // namespace hazmap
