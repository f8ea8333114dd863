#pragma once
// Internal (PCD and PLY readers): which field names feed which LabeledCloud channel, and a sink
// that drops non-finite points, validates labels and maps them to classes.
#include <array>
#include <cmath>
#include <string>

#include "hazmap/core/class_table.hpp"
#include "hazmap/core/error.hpp"
#include "hazmap/core/labeled_cloud.hpp"
#include "hazmap/io/read_stats.hpp"
#include "io/io_detail.hpp"

namespace hazmap::io_fields {

// Field names (compared lower-case) per channel, in order of preference.
inline constexpr std::array<const char*, 4> kIntensityNames{"intensity", "remission", "reflectance",
                                                            "scalar_intensity"};
inline constexpr std::array<const char*, 4> kLabelNames{"label", "class", "semantic", "scalar_label"};
inline constexpr std::array<const char*, 3> kTimeNames{"timestamp", "time", "t"};
inline constexpr std::array<const char*, 1> kPropertyNames{"property"};

/// First field whose lower-cased name is in `names`, or nullptr.
template <typename Field, typename Names>
const Field* findField(const std::vector<Field>& fields, const Names& names) {
  for (const char* n : names)
    for (const auto& f : fields)
      if (io_detail::toLower(f.name) == n) return &f;
  return nullptr;
}

/// Collects points; drops (and counts) those with a non-finite coordinate or channel value.
class ChannelSink {
 public:
  template <typename F>
  ChannelSink(std::string where, const ClassTable& table, bool class_ids, const F* intensity,
              const F* label, const F* time, const F* property)
      : where_(std::move(where)),
        table_(table),
        class_ids_(class_ids),
        hi_(intensity != nullptr),
        hl_(label != nullptr),
        ht_(time != nullptr),
        hp_(property != nullptr) {
    if (hi_) cloud_.enableIntensity();
    if (ht_) cloud_.enableTimestamps();
    if (hp_) cloud_.enableProperty();
  }

  void reserve(std::size_t n) { cloud_.reserve(n); }

  void addXyz(double x, double y, double z) {
    const Eigen::Vector3f p(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    if (!p.allFinite()) {
      ++dropped_;
      return;
    }
    cloud_.points.push_back(p);
    cloud_.classes.push_back(0);
  }

  void add(double x, double y, double z, double intensity, double label, double time, double property,
           std::size_t index) {
    const Eigen::Vector3f p(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    const float fi = static_cast<float>(intensity), fp = static_cast<float>(property);
    if (!p.allFinite() || (hi_ && !std::isfinite(fi)) || (ht_ && !std::isfinite(time)) ||
        (hp_ && !std::isfinite(fp))) {
      ++dropped_;
      return;
    }
    ClassId c = 0;
    if (hl_) {
      const double limit = class_ids_ ? 65535.0 : 4294967295.0;
      if (!(label >= 0.0 && label <= limit) || label != std::floor(label))
        fail(where_, "point " + std::to_string(index) + ": label " + std::to_string(label) +
                         (class_ids_ ? " is not a class id (0..65535)" : " is not a valid label"));
      const auto raw = static_cast<std::uint32_t>(label);
      c = class_ids_ ? static_cast<ClassId>(raw) : table_.mapRaw(raw & 0xFFFFu);
    }
    cloud_.points.push_back(p);
    cloud_.classes.push_back(c);
    if (hi_) cloud_.intensity.push_back(fi);
    if (ht_) cloud_.timestamps.push_back(time);
    if (hp_) cloud_.property.push_back(fp);
  }

  LabeledCloud finish(std::size_t points_in_file, ReadStats* stats) {
    if (stats) {
      stats->points_in_file = points_in_file;
      stats->dropped_non_finite = dropped_;
    }
    return std::move(cloud_);
  }

 private:
  std::string where_;
  const ClassTable& table_;
  bool class_ids_;
  bool hi_, hl_, ht_, hp_;
  std::size_t dropped_ = 0;
  LabeledCloud cloud_;
};

}  // namespace hazmap::io_fields
