// `hazmap replay --camera`: recorded camera images as RTP beside the capture (replay_cameras.hpp).
#include "replay_cameras.hpp"

#include <algorithm>
#include <cmath>

#include "hazmap/core/error.hpp"

namespace hazmap::cli {

ReplayCameras::ReplayCameras(const std::vector<std::string>& yamls, const std::string& host, int first_port) {
  if (!yamls.empty() && (first_port < 1 || first_port + static_cast<int>(yamls.size()) - 1 > 65535))
    fail("--camera-port", std::to_string(first_port) + " is no UDP port for " + std::to_string(yamls.size()) + " camera(s)");
  for (std::size_t k = 0; k < yamls.size(); ++k) {
    Camera c;
    c.calibration = readCameraYaml(yamls[k]);
    const std::filesystem::path dir =
        c.calibration.images.empty() ? std::filesystem::absolute(yamls[k]).parent_path() : c.calibration.images;
    c.folder = std::make_unique<ImageFolder>(dir);
    for (std::size_t i = 0; i < c.folder->size(); ++i)
      images_.push_back({std::llround(c.folder->stamp(i) * 1e9), k, i});
    c.sender = std::make_unique<GstFrameSender>(host, first_port + static_cast<int>(k), yamls[k]);
    cameras_.push_back(std::move(c));
  }
  std::stable_sort(images_.begin(), images_.end(), [](const Image& a, const Image& b) { return a.time_ns < b.time_ns; });
}

std::optional<std::int64_t> ReplayCameras::firstTime() const {
  if (images_.empty()) return std::nullopt;
  return images_.front().time_ns;
}

void ReplayCameras::sendUntil(std::optional<std::int64_t> until_ns, const std::function<void(std::int64_t)>& pace) {
  for (; next_ < images_.size() && (!until_ns || images_[next_].time_ns <= *until_ns); ++next_) {
    const Image& image = images_[next_];
    Camera& c = cameras_[image.camera];
    const Gray16 raw = readGray16(c.folder->file(image.index));
    std::vector<std::uint8_t> bytes(raw.pixels.size() * 2);
    for (std::size_t k = 0; k < raw.pixels.size(); ++k) {  // GRAY16_LE: the counts unchanged
      bytes[2 * k] = static_cast<std::uint8_t>(raw.pixels[k] & 0xFF);
      bytes[2 * k + 1] = static_cast<std::uint8_t>(raw.pixels[k] >> 8);
    }
    pace(image.time_ns);
    c.sender->send(raw.width, raw.height, "GRAY16_LE", bytes, image.time_ns - images_.front().time_ns);
    ++sent_;
  }
}

}  // namespace hazmap::cli
