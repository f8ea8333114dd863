// Live scans labelled from the live cameras, and the label spool that gives the run folder's
// second pass the same labels (live_labels.hpp).
//
// Spool: "HZLABELS1\n", u32 channel count, per channel u32 length + name; then per labelled scan
// u64 scan index, u64 point count, the classes (u16 each), each channel's values (f32 each);
// little endian as the machine writes it (the spool is read back by the process that wrote it).
#include "hazmap/properties/live_labels.hpp"

#include <cstring>
#include <fstream>

#include "hazmap/core/error.hpp"
#include "hazmap/properties/label_sequence.hpp"

namespace hazmap {

namespace {

constexpr char kMagic[] = "HZLABELS1\n";

template <class T>
void put(std::FILE* f, const T* data, std::size_t n, const std::filesystem::path& where) {
  if (n > 0 && std::fwrite(data, sizeof(T), n, f) != n) fail(where.string(), "cannot write the label spool (disk full?)");
}

}  // namespace

LiveLabelledScans::LiveLabelledScans(ScanSource& scans, LiveLabeler& labeler, const std::filesystem::path& spool)
    : scans_(scans), labeler_(labeler), table_(cameraClassTable(scans.classTable())), spool_path_(spool) {
  if (spool.empty()) return;
  spool_ = std::fopen(spool.c_str(), "wb");
  if (!spool_) fail(spool.string(), "cannot create the label spool");
  put(spool_, kMagic, sizeof kMagic - 1, spool);
  const auto count = static_cast<std::uint32_t>(labeler.channels().size());
  put(spool_, &count, 1, spool);
  for (const std::string& name : labeler.channels()) {
    const auto length = static_cast<std::uint32_t>(name.size());
    put(spool_, &length, 1, spool);
    put(spool_, name.data(), name.size(), spool);
  }
}

LiveLabelledScans::~LiveLabelledScans() {
  if (spool_) std::fclose(spool_);
}

std::optional<Scan> LiveLabelledScans::next() {
  std::optional<Scan> scan = scans_.next();
  if (!scan) return scan;
  const ScanLabels labels = labeler_.label(scan->cloud, scan->stamp);
  PropertyLabeler::apply(labels, scan->cloud);
  if (spool_) {
    const std::uint64_t head[2] = {scan->index, scan->cloud.size()};
    put(spool_, head, 2, spool_path_);
    put(spool_, labels.classes.data(), labels.classes.size(), spool_path_);
    for (const auto& channel : labels.channels) put(spool_, channel.data(), channel.size(), spool_path_);
  }
  last_channels_.clear();
  for (std::size_t c = 0; c < labels.channels.size(); ++c)
    last_channels_.push_back({labeler_.channels().at(c), std::move(labels.channels[c])});
  return scan;
}

std::string LiveLabelledScans::describe() const {
  std::string names;
  for (const auto& c : labeler_.cameras()) names += (names.empty() ? "" : ", ") + c->calibration().name;
  return scans_.describe() + ", labelled live from " + names;
}

void LiveLabelledScans::flush() {
  if (spool_ && std::fflush(spool_) != 0) fail(spool_path_.string(), "cannot write the label spool (disk full?)");
}

namespace {

class SpoolLabels final : public ScanSource {
 public:
  SpoolLabels(std::unique_ptr<ScanSource> scans, const std::filesystem::path& spool, bool read_channels)
      : scans_(std::move(scans)), table_(cameraClassTable(scans_->classTable())), where_(spool.string()),
        in_(spool, std::ios::binary), read_channels_(read_channels) {
    if (!in_) fail(where_, "cannot open the label spool");
    char magic[sizeof kMagic - 1];
    std::uint32_t count = 0;
    if (!in_.read(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof magic) != 0 || !get(&count, 1) || count > 64)
      fail(where_, "is not a label spool of hazmap live");
    for (std::uint32_t c = 0; c < count; ++c) {
      std::uint32_t length = 0;
      if (!get(&length, 1) || length > 256) fail(where_, "label spool: a channel name is cut or too long");
      std::string name(length, '\0');
      if (!get(name.data(), length)) fail(where_, "label spool: a channel name is cut");
      channels_.push_back(std::move(name));
    }
  }

  std::optional<Scan> next() override {
    std::optional<Scan> scan = scans_->next();
    if (!scan || !findRecord(scan->index)) return scan;  // none: received, never labelled
    if (points_ != scan->cloud.size())
      fail(where_, "label spool: scan " + std::to_string(scan->index) + " had " + std::to_string(points_) +
                       " points when labelled, " + std::to_string(scan->cloud.size()) + " now");
    ScanLabels labels;
    labels.classes.resize(points_);
    labels.channels.assign(channels_.size(), std::vector<float>(points_));
    if (!get(labels.classes.data(), points_)) return scan;  // a record cut by a crash: the end
    for (auto& v : labels.channels)
      if (!get(v.data(), points_)) return scan;
    PropertyLabeler::apply(labels, scan->cloud);
    if (read_channels_)
      for (std::size_t c = 0; c < channels_.size(); ++c) scan->channels.push_back({channels_[c], labels.channels[c]});
    return scan;
  }
  std::optional<std::size_t> size() const override { return scans_->size(); }
  const ClassTable& classTable() const override { return table_; }
  std::string describe() const override { return scans_->describe() + ", labels from " + where_; }

 private:
  template <class T>
  bool get(T* data, std::size_t n) {
    return static_cast<bool>(in_.read(reinterpret_cast<char*>(data), static_cast<std::streamsize>(n * sizeof(T))));
  }
  /// Positions the stream at the data of scan `index`'s record (records of scans this pass does
  /// not have are skipped); false when the spool has none for it.
  bool findRecord(std::size_t index) {
    while (true) {
      if (!pending_) {
        std::uint64_t head[2];
        if (!get(head, 2)) return false;
        if (head[1] > (std::uint64_t(1) << 32)) fail(where_, "label spool: a record of " + std::to_string(head[1]) + " points");
        pending_index_ = head[0], points_ = head[1], pending_ = true;
      }
      if (pending_index_ > index) return false;  // a later scan's
      pending_ = false;
      if (pending_index_ == index) return true;
      in_.seekg(static_cast<std::streamoff>(points_ * (sizeof(ClassId) + sizeof(float) * channels_.size())), std::ios::cur);
    }
  }

  std::unique_ptr<ScanSource> scans_;
  ClassTable table_;
  std::string where_;
  std::ifstream in_;
  bool read_channels_;
  std::vector<std::string> channels_;
  bool pending_ = false;  // a record's head is read, its data not yet
  std::uint64_t pending_index_ = 0, points_ = 0;
};

}  // namespace

std::unique_ptr<ScanSource> relabelFromSpool(std::unique_ptr<ScanSource> scans, const std::filesystem::path& spool,
                                             bool read_channels) {
  return std::make_unique<SpoolLabels>(std::move(scans), spool, read_channels);
}

}  // namespace hazmap
