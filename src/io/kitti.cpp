#include "hazmap/io/kitti.hpp"

#include <array>
#include <cmath>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/io/atomic_file.hpp"
#include "io/io_detail.hpp"

namespace hazmap {

namespace {

constexpr std::size_t kBinRecord = 4 * sizeof(float);

std::vector<std::uint32_t> labelsFromBytes(const io_detail::FileBytes& bytes,
                                           const std::filesystem::path& path) {
  if (bytes.size % sizeof(std::uint32_t) != 0)
    fail(path.string(), "truncated: size " + std::to_string(bytes.size) +
                            " bytes is not a multiple of 4 (one uint32 label per point)");
  std::vector<std::uint32_t> labels(bytes.size / sizeof(std::uint32_t));
  if (!labels.empty()) std::memcpy(labels.data(), bytes.begin(), bytes.size);
  return labels;
}

/// Decodes a .bin buffer; `labels` (already checked to have one entry per record) → classes.
LabeledCloud decodeBin(const io_detail::FileBytes& bytes, const std::uint32_t* labels,
                       const ClassTable* table, ReadStats* stats) {
  const std::size_t n = bytes.size / kBinRecord;
  LabeledCloud cloud;
  cloud.enableIntensity();
  cloud.resize(n);
  Eigen::Vector3f* pts = cloud.points.data();
  float* inten = cloud.intensity.data();
  ClassId* cls = cloud.classes.data();
  const char* src = bytes.begin();
  std::size_t w = 0;
  for (std::size_t i = 0; i < n; ++i) {
    float v[4];
    std::memcpy(v, src + i * kBinRecord, kBinRecord);
    if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]) && std::isfinite(v[3])))
      continue;
    pts[w] = Eigen::Vector3f(v[0], v[1], v[2]);
    inten[w] = v[3];
    cls[w] = labels ? table->mapRaw(labels[i] & 0xFFFFu) : ClassId{0};
    ++w;
  }
  cloud.resize(w);
  if (stats) {
    stats->points_in_file = n;
    stats->dropped_non_finite = n - w;
    stats->format = "kitti-bin";
    stats->fields = {"x", "y", "z", "remission"};
    if (labels) stats->fields.push_back("label");
  }
  return cloud;
}

io_detail::FileBytes readBinBytes(const std::filesystem::path& bin) {
  io_detail::FileBytes bytes = io_detail::readFileBytes(bin);
  if (bytes.size % kBinRecord != 0)
    fail(bin.string(), "truncated: size " + std::to_string(bytes.size) +
                           " bytes is not a multiple of 16 (float32 x, y, z, remission per point)");
  return bytes;
}

}  // namespace

LabeledCloud readKittiBin(const std::filesystem::path& bin, ReadStats* stats) {
  const auto bytes = readBinBytes(bin);
  return decodeBin(bytes, nullptr, nullptr, stats);
}

std::vector<std::uint32_t> readSemanticKittiLabels(const std::filesystem::path& label) {
  return labelsFromBytes(io_detail::readFileBytes(label), label);
}

bool looksLikeSemanticKittiLabels(const std::vector<std::uint32_t>& labels) {
  // semantic-kitti.yaml's `labels:` (the ids a SemanticKITTI .label file may hold).
  static constexpr std::uint32_t kIds[] = {0,  1,  10, 11, 13, 15, 16, 18, 20, 30,  31,  32,  40,  44,  48,  49, 50,
                                           51, 52, 60, 70, 71, 72, 80, 81, 99, 252, 253, 254, 255, 256, 257, 258, 259};
  static const std::array<bool, 260> known = [] {
    std::array<bool, 260> k{};
    for (const std::uint32_t id : kIds) k[id] = true;
    return k;
  }();
  const ClassTable defaults = ClassTable::defaults();
  bool beyond_defaults = false;
  for (const std::uint32_t label : labels) {
    const std::uint32_t id = label & 0xFFFFu;
    if (id >= known.size() || !known[id]) return false;
    beyond_defaults = beyond_defaults || !defaults.contains(static_cast<ClassId>(id));
  }
  return beyond_defaults;
}

LabeledCloud readKittiScan(const std::filesystem::path& bin,
                           const std::optional<std::filesystem::path>& label,
                           const ClassTable& table, ReadStats* stats) {
  const auto bytes = readBinBytes(bin);
  if (!label) return decodeBin(bytes, nullptr, nullptr, stats);
  const auto labels = readSemanticKittiLabels(*label);
  const std::size_t n = bytes.size / kBinRecord;
  if (labels.size() != n)
    fail(label->string(), "has " + std::to_string(labels.size()) + " labels but " + bin.string() +
                              " has " + std::to_string(n) + " points");
  return decodeBin(bytes, labels.data(), &table, stats);
}

void writeKittiBin(const std::filesystem::path& bin, const LabeledCloud& cloud) {
  cloud.checkConsistent(bin.string());
  const std::size_t n = cloud.size();
  const bool has_i = !cloud.intensity.empty();
  std::string buf(n * kBinRecord, '\0');
  char* dst = buf.data();
  for (std::size_t i = 0; i < n; ++i) {
    const float v[4] = {cloud.points[i].x(), cloud.points[i].y(), cloud.points[i].z(),
                        has_i ? cloud.intensity[i] : 0.0f};
    std::memcpy(dst + i * kBinRecord, v, kBinRecord);
  }
  writeFileAtomically(bin, [&](std::ostream& out) { out.write(buf.data(), std::streamsize(buf.size())); });
}

void writeSemanticKittiLabels(const std::filesystem::path& label, const LabeledCloud& cloud) {
  cloud.checkConsistent(label.string());
  std::vector<std::uint32_t> raw(cloud.classes.begin(), cloud.classes.end());
  writeFileAtomically(label, [&](std::ostream& out) {
    out.write(reinterpret_cast<const char*>(raw.data()), std::streamsize(raw.size() * 4));
  });
}

}  // namespace hazmap
