#include "hazmap/map/global_map.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <limits>
#include <array>
#include <unordered_set>
#include <cmath>

#include "hazmap/core/error.hpp"
#include "hazmap/core/voxel_key.hpp"
#include "hazmap/core/se3.hpp"
#include "map/voxel_hash.hpp"

namespace hazmap {

// ---- frame ranges ----------------------------------------------------------------------------

std::size_t countFrames(const std::vector<FrameRange>& ranges) {
  std::size_t n = 0;
  for (const auto& r : ranges) n += std::size_t(r.last) - r.first + 1;
  return n;
}

std::vector<FrameRange> unionRanges(std::vector<FrameRange> ranges) {
  std::sort(ranges.begin(), ranges.end(),
            [](const FrameRange& a, const FrameRange& b) { return a.first < b.first; });
  std::vector<FrameRange> out;
  for (const auto& r : ranges) {
    if (!out.empty() && std::uint64_t(r.first) <= std::uint64_t(out.back().last) + 1)
      out.back().last = std::max(out.back().last, r.last);
    else
      out.push_back(r);
  }
  return out;
}

namespace {

// ---- voxel keys (core/voxel_key.hpp) ----------------------------------------------------------
std::uint64_t packKey(const Eigen::Vector3i& v) {
  std::uint64_t key = 0;
  voxelKey(v.x(), v.y(), v.z(), key);  // callers keep indices within ±2^20 voxels
  return key;
}
Eigen::Vector3i unpackKey(std::uint64_t k) {
  const auto [x, y, z] = unpackVoxelKey(k);
  return {int(x), int(y), int(z)};
}
// The map's cells are written in (z, y, x) order, as before the keys were shared.
std::uint64_t zMajorKey(std::uint64_t k) {
  const auto [x, y, z] = unpackVoxelKey(k);
  std::uint64_t key = 0;
  voxelKey(z, y, x, key);
  return key;
}
int floorDiv2(int v) { return v >= 0 ? v / 2 : -((-v + 1) / 2); }

constexpr int kSlots = 4;

struct Cell {
  Eigen::Vector3f offset_sum = Eigen::Vector3f::Zero();  // Σ (p − cell origin): small numbers
  std::uint32_t count = 0;
  std::array<std::uint32_t, kSlots> class_counts{};
  std::array<ClassId, kSlots> class_ids{};
  std::uint8_t used_slots = 0;
  float property_sum = 0;
  std::uint32_t property_count = 0;
  float property_max = -std::numeric_limits<float>::infinity();

  // Exact for up to kSlots distinct classes in one cell; beyond that the rarest slot is
  // replaced, which cannot change a clear majority.
  void vote(ClassId c, std::uint32_t n) {
    for (int s = 0; s < used_slots; ++s)
      if (class_ids[s] == c) {
        class_counts[s] += n;
        return;
      }
    if (used_slots < kSlots) {
      class_ids[used_slots] = c;
      class_counts[used_slots] = n;
      ++used_slots;
      return;
    }
    int weakest = 0;
    for (int s = 1; s < kSlots; ++s)
      if (class_counts[s] < class_counts[weakest]) weakest = s;
    if (class_counts[weakest] <= n) {
      class_ids[weakest] = c;
      class_counts[weakest] = n;
    }
  }
  std::pair<ClassId, std::uint32_t> majority() const {
    ClassId best = 0;
    std::uint32_t best_n = 0;
    for (int s = 0; s < used_slots; ++s)
      if (class_counts[s] > best_n || (class_counts[s] == best_n && class_ids[s] < best)) {
        best = class_ids[s];
        best_n = class_counts[s];
      }
    return {best, best_n};
  }
};

struct FrameRecord {
  std::vector<FrameRange> ranges;  // sorted, disjoint
  std::uint32_t count = 0;         // frames that saw the cell (exact for in-order insertion)
  std::int64_t last_frame = -1;

  void add(std::uint32_t f, std::size_t max_ranges) {
    if (std::int64_t(f) == last_frame) return;  // more points of the same frame
    if (std::int64_t(f) > last_frame) {  // the normal, in-order case
      ++count;
      last_frame = f;
      if (!ranges.empty() && ranges.back().last + 1 == f)
        ranges.back().last = f;
      else
        ranges.push_back({f, f});
    } else {
      auto it = std::lower_bound(ranges.begin(), ranges.end(), f,
                                 [](const FrameRange& r, std::uint32_t v) { return r.last < v; });
      if (it != ranges.end() && it->first <= f) return;  // already recorded
      ++count;
      ranges.insert(it, {f, f});
      ranges = unionRanges(std::move(ranges));
    }
    cap(max_ranges);
  }
  void merge(const FrameRecord& other, std::size_t max_ranges) {
    std::vector<FrameRange> all = ranges;
    all.insert(all.end(), other.ranges.begin(), other.ranges.end());
    ranges = unionRanges(std::move(all));
    // Both are upper bounds of the true count; the union is exact while no list was capped.
    count = std::uint32_t(std::min<std::size_t>(countFrames(ranges), std::size_t(count) + other.count));
    last_frame = std::max(last_frame, other.last_frame);
    cap(max_ranges);
  }
  // Merges the two neighbouring ranges with the smallest gap until at most max_ranges remain.
  void cap(std::size_t max_ranges) {
    while (ranges.size() > max_ranges && ranges.size() > 1) {
      std::size_t best = 0;
      std::uint32_t best_gap = ~0u;
      for (std::size_t i = 0; i + 1 < ranges.size(); ++i) {
        const std::uint32_t gap = ranges[i + 1].first - ranges[i].last;
        if (gap < best_gap) {
          best_gap = gap;
          best = i;
        }
      }
      ranges[best].last = ranges[best + 1].last;
      ranges.erase(ranges.begin() + std::ptrdiff_t(best) + 1);
    }
  }
};

// Per channel, over a cell's property-class points: only cells that received property points
// with named channels hold one (as frame records), so plain cells pay nothing.
struct ChannelAccumulator {
  double sum = 0;
  std::uint32_t count = 0;
  float max = -std::numeric_limits<float>::infinity();
  void add(float v) {
    sum += v;
    ++count;
    max = std::max(max, v);
  }
  void merge(const ChannelAccumulator& o) {
    sum += o.sum;
    count += o.count;
    max = std::max(max, o.max);
  }
};
struct ChannelRecord {
  std::vector<ChannelAccumulator> channels;  // GlobalMap::channelNames() order
  void merge(const ChannelRecord& o) {
    if (channels.size() < o.channels.size()) channels.resize(o.channels.size());
    for (std::size_t k = 0; k < o.channels.size(); ++k) channels[k].merge(o.channels[k]);
  }
};

}  // namespace

// ---- config ------------------------------------------------------------------------------------

// ---- the map -----------------------------------------------------------------------------------

struct GlobalMap::Impl {
  GlobalMapConfig config;
  ClassTable table;
  std::vector<std::int8_t> class_kind;  // per class id: -1 unknown, 0 plain, 1 property
  double voxel = 0.1;
  int coarsenings = 0;
  std::size_t frames = 0, points = 0;
  bool any_property_channel = false;
  detail::VoxelHashMap<Cell> cells;
  detail::VoxelHashMap<FrameRecord> frame_records;  // only cells that received property points
  std::vector<std::string> channel_names;
  detail::VoxelHashMap<ChannelRecord> channel_records;  // property cells of scans with named channels

  // Slot of each of the scan's channels in channel_names (new names are appended).
  std::vector<std::size_t> channelSlots(std::span<const PointChannel> channels, std::size_t points,
                                        const std::string& where) {
    std::vector<std::size_t> slots;
    for (const PointChannel& c : channels) {
      if (c.values.size() != points)
        fail(where, "channel '" + c.name + "' has " + std::to_string(c.values.size()) + " values for " +
                        std::to_string(points) + " points");
      const auto it = std::find(channel_names.begin(), channel_names.end(), c.name);
      slots.push_back(std::size_t(it - channel_names.begin()));
      if (it == channel_names.end()) channel_names.push_back(c.name);
    }
    return slots;
  }
  void addChannels(std::uint64_t key, std::span<const PointChannel> channels, const std::vector<std::size_t>& slots,
                   std::size_t i) {
    ChannelRecord& rec = channel_records[key];
    if (rec.channels.size() < channel_names.size()) rec.channels.resize(channel_names.size());
    for (std::size_t k = 0; k < channels.size(); ++k)
      if (const float v = channels[k].values[i]; std::isfinite(v)) rec.channels[slots[k]].add(v);
  }

  static std::uint64_t parentKey(std::uint64_t key) {
    const Eigen::Vector3i idx = unpackKey(key);
    return packKey(Eigen::Vector3i(floorDiv2(idx.x()), floorDiv2(idx.y()), floorDiv2(idx.z())));
  }

  void coarsen() {
    // Old cells are drained as they are merged, so the peak stays near one map, not two.
    detail::VoxelHashMap<Cell> merged;
    cells.dropIndex();
    while (!cells.empty()) {
      auto [key, c] = cells.popBackUnindexed();
      const Eigen::Vector3i idx = unpackKey(key);
      const Eigen::Vector3i nidx(floorDiv2(idx.x()), floorDiv2(idx.y()), floorDiv2(idx.z()));
      Cell& m = merged[packKey(nidx)];
      // Offsets were relative to the old origin idx·voxel; re-express them relative to the new
      // origin nidx·2·voxel (they differ by 0 or one old voxel per axis).
      const Eigen::Vector3f shift = ((idx - 2 * nidx).cast<double>() * voxel).cast<float>();
      m.offset_sum += c.offset_sum + float(c.count) * shift;
      m.count += c.count;
      for (int s = 0; s < c.used_slots; ++s) m.vote(c.class_ids[s], c.class_counts[s]);
      m.property_sum += c.property_sum;
      m.property_count += c.property_count;
      m.property_max = std::max(m.property_max, c.property_max);
    }
    detail::VoxelHashMap<FrameRecord> records;
    frame_records.dropIndex();
    while (!frame_records.empty()) {
      auto [key, rec] = frame_records.popBackUnindexed();
      FrameRecord& dst = records[parentKey(key)];
      if (dst.ranges.empty() && dst.count == 0)
        dst = std::move(rec);
      else
        dst.merge(rec, config.max_frame_ranges);
    }
    detail::VoxelHashMap<ChannelRecord> channel_merged;
    channel_records.dropIndex();
    while (!channel_records.empty()) {
      auto [key, rec] = channel_records.popBackUnindexed();
      channel_merged[parentKey(key)].merge(rec);
    }
    cells.swap(merged);
    frame_records.swap(records);
    channel_records.swap(channel_merged);
    voxel *= 2.0;
    ++coarsenings;
  }
};

GlobalMap::GlobalMap(GlobalMapConfig config, ClassTable table) : impl_(std::make_unique<Impl>()) {
  config.validate();
  impl_->config = config;
  impl_->voxel = config.voxel_size;
  impl_->class_kind.assign(65536, -1);
  for (ClassId id : table.ids()) impl_->class_kind[id] = table.isProperty(id) ? 1 : 0;
  impl_->table = std::move(table);
}
GlobalMap::~GlobalMap() = default;
GlobalMap::GlobalMap(GlobalMap&&) noexcept = default;
GlobalMap& GlobalMap::operator=(GlobalMap&&) noexcept = default;

void GlobalMap::insert(std::size_t frame, const LabeledCloud& scan, const Eigen::Isometry3d& T,
                       std::span<const PointChannel> channels) {
  Impl& m = *impl_;
  const std::string where = "global map: frame " + std::to_string(frame);
  if (!isFinite(T)) fail(where, "pose is not finite");
  if (frame > 0xFFFFFFF0u) fail(where, "frame index too large");
  if (scan.classes.size() != scan.size()) fail(where, "scan has " + std::to_string(scan.size()) +
                                                          " points but " + std::to_string(scan.classes.size()) +
                                                          " classes");
  const bool has_property = !scan.property.empty() && scan.property.size() == scan.size();
  const std::vector<std::size_t> slots = m.channelSlots(channels, scan.size(), where);
  for (ClassId c : scan.classes)
    if (m.class_kind[c] < 0) fail(where, "class " + std::to_string(c) + " is not in the class table");
  const double min_r2 = m.config.min_range * m.config.min_range;
  const double max_r2 = m.config.max_range > 0 ? m.config.max_range * m.config.max_range : 0.0;
  const double inv = 1.0 / m.voxel;
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3f& ps = scan.points[i];
    if (!ps.allFinite()) continue;
    const Eigen::Vector3d pd = ps.cast<double>();
    const double r2 = pd.squaredNorm();
    if (r2 < min_r2 || (max_r2 > 0 && r2 > max_r2)) continue;
    const Eigen::Vector3d pw = R * pd + t;
    const Eigen::Vector3d q = (pw * inv).array().floor();
    if ((q.array().abs() >= double(kVoxelKeyBias)).any()) continue;  // beyond ±2^20 voxels
    const Eigen::Vector3i idx = q.cast<int>();
    const std::uint64_t key = packKey(idx);
    Cell& c = m.cells[key];
    c.offset_sum += (pw - idx.cast<double>() * m.voxel).cast<float>();
    ++c.count;
    const ClassId cls = scan.classes[i];
    c.vote(cls, 1);
    if (m.class_kind[cls] == 1) {
      if (has_property && std::isfinite(scan.property[i])) {
        c.property_sum += scan.property[i];
        ++c.property_count;
        c.property_max = std::max(c.property_max, scan.property[i]);
      }
      m.frame_records[key].add(std::uint32_t(frame), m.config.max_frame_ranges);
      if (!channels.empty()) m.addChannels(key, channels, slots, i);
    }
    ++m.points;
  }
  if (has_property) m.any_property_channel = true;
  ++m.frames;
  while (m.cells.size() > m.config.max_voxels) m.coarsen();
}

void GlobalMap::insertMap(const GlobalMap& part, const Eigen::Isometry3d& T) {
  Impl& m = *impl_;
  const Impl& p = *part.impl_;
  if (!isFinite(T)) fail("global map", "a part's transform is not finite");
  if (p.table.ids() != m.table.ids()) fail("global map", "a part made with another class table");
  std::vector<std::size_t> slots;  // the part's channel k is this map's slots[k]
  for (const std::string& name : p.channel_names) {
    const auto it = std::find(m.channel_names.begin(), m.channel_names.end(), name);
    slots.push_back(std::size_t(it - m.channel_names.begin()));
    if (it == m.channel_names.end()) m.channel_names.push_back(name);
  }
  const Eigen::Matrix3d R = T.linear();
  const Eigen::Vector3d t = T.translation();
  const bool unmoved = T.matrix() == Eigen::Matrix4d::Identity();
  std::unordered_set<std::uint64_t> landed;  // cells the part's moved cells went to
  for (std::size_t i = 0; i < p.cells.size(); ++i) {
    const std::uint64_t part_key = p.cells.keyAt(i);
    const Cell& c = p.cells.valueAt(i);
    const Eigen::Vector3i part_idx = unpackKey(part_key);
    Eigen::Vector3i idx = part_idx;
    Eigen::Vector3f offset_sum = c.offset_sum;
    // Unmoved, on the same grid: each cell stays where its points went, spread and all.
    if (!unmoved || p.voxel != m.voxel) {
      const Eigen::Vector3d centroid = part_idx.cast<double>() * p.voxel + (c.offset_sum / float(c.count)).cast<double>();
      const Eigen::Vector3d pw = R * centroid + t;
      const Eigen::Vector3d q = (pw / m.voxel).array().floor();
      if ((q.array().abs() >= double(kVoxelKeyBias) - 1).any()) continue;  // beyond ±2^20 voxels
      idx = q.cast<int>();
      // Two of the part's cells in one: the points of the later one would mostly have gone to
      // the neighbour across the nearest face (their centroid is near it), so it goes there if
      // that is still free of the part, its centroid put just inside. Keeps a moved surface
      // whole instead of thinning it where its centroids crowd.
      if (!landed.insert(packKey(idx)).second) {
        const Eigen::Vector3d within = pw / m.voxel - q;  // in [0, 1)³
        int axis = 0;
        double nearest = 1;
        for (int k = 0; k < 3; ++k)
          for (const double d : {within[k], 1 - within[k]})
            if (d < nearest) nearest = d, axis = k;
        Eigen::Vector3i across = idx;
        across[axis] += within[axis] < 0.5 ? -1 : 1;
        if (landed.insert(packKey(across)).second) idx = across;
      }
      const Eigen::Vector3d origin = idx.cast<double>() * m.voxel;
      const Eigen::Vector3d inside = (pw - origin).cwiseMax(0.001 * m.voxel).cwiseMin(0.999 * m.voxel);
      offset_sum = float(c.count) * inside.cast<float>();
    }
    const std::uint64_t key = packKey(idx);
    Cell& d = m.cells[key];
    d.offset_sum += offset_sum;
    d.count += c.count;
    for (int s = 0; s < c.used_slots; ++s) d.vote(c.class_ids[s], c.class_counts[s]);
    d.property_sum += c.property_sum;
    d.property_count += c.property_count;
    d.property_max = std::max(d.property_max, c.property_max);
    if (const FrameRecord* rec = p.frame_records.find(part_key)) m.frame_records[key].merge(*rec, m.config.max_frame_ranges);
    if (const ChannelRecord* rec = p.channel_records.find(part_key)) {
      ChannelRecord& dst = m.channel_records[key];
      if (dst.channels.size() < m.channel_names.size()) dst.channels.resize(m.channel_names.size());
      for (std::size_t k = 0; k < rec->channels.size(); ++k) dst.channels[slots[k]].merge(rec->channels[k]);
    }
    while (m.cells.size() > m.config.max_voxels) m.coarsen();
  }
  m.frames += p.frames;
  m.points += p.points;
  m.any_property_channel = m.any_property_channel || p.any_property_channel;
}

std::size_t GlobalMap::size() const { return impl_->cells.size(); }
std::size_t GlobalMap::frames() const { return impl_->frames; }
std::size_t GlobalMap::pointsInserted() const { return impl_->points; }
double GlobalMap::voxelSize() const { return impl_->voxel; }
int GlobalMap::coarsenings() const { return impl_->coarsenings; }
const GlobalMapConfig& GlobalMap::config() const { return impl_->config; }
const ClassTable& GlobalMap::classTable() const { return impl_->table; }
const std::vector<std::string>& GlobalMap::channelNames() const { return impl_->channel_names; }

std::size_t GlobalMap::memoryBytes() const {
  // Node (key + value + next pointer) plus one bucket pointer per element, and frame lists.
  std::size_t bytes = impl_->cells.memoryBytes() + impl_->frame_records.memoryBytes();
  for (std::size_t i = 0; i < impl_->frame_records.size(); ++i)
    bytes += impl_->frame_records.valueAt(i).ranges.capacity() * sizeof(FrameRange);
  bytes += impl_->channel_records.memoryBytes();
  for (std::size_t i = 0; i < impl_->channel_records.size(); ++i)
    bytes += impl_->channel_records.valueAt(i).channels.capacity() * sizeof(ChannelAccumulator);
  return bytes;
}

std::vector<MapCell> GlobalMap::cells() const {
  const Impl& m = *impl_;
  std::vector<std::pair<std::uint64_t, std::size_t>> order;
  order.reserve(m.cells.size());
  for (std::size_t i = 0; i < m.cells.size(); ++i) order.emplace_back(zMajorKey(m.cells.keyAt(i)), i);
  // Sorted (z, y, x): deterministic regardless of insertion or hash order.
  std::sort(order.begin(), order.end());
  std::vector<MapCell> out;
  out.reserve(order.size());
  for (const auto& [sort_key, index] : order) {
    const std::uint64_t key = m.cells.keyAt(index);
    const Cell& c = m.cells.valueAt(index);
    MapCell v;
    v.index = unpackKey(key);
    v.centroid = ((v.index.cast<double>() * m.voxel) + (c.offset_sum / float(c.count)).cast<double>()).cast<float>();
    v.points = c.count;
    std::tie(v.label, v.label_points) = c.majority();
    v.property_samples = c.property_count;
    v.property_mean = c.property_count ? c.property_sum / float(c.property_count) : 0.0f;
    v.property_max = c.property_count ? c.property_max : 0.0f;
    if (const FrameRecord* rec = m.frame_records.find(key)) {
      v.frames = rec->ranges;
      v.frame_count = rec->count;
    }
    if (!m.channel_names.empty()) {
      v.channels.resize(m.channel_names.size());
      if (const ChannelRecord* rec = m.channel_records.find(key))
        for (std::size_t k = 0; k < rec->channels.size(); ++k)
          if (const ChannelAccumulator& a = rec->channels[k]; a.count)
            v.channels[k] = {float(a.sum / double(a.count)), a.max, a.count};
    }
    out.push_back(std::move(v));
  }
  return out;
}

LabeledCloud GlobalMap::cloud() const {
  const std::vector<MapCell> all = cells();
  LabeledCloud out;
  if (impl_->any_property_channel) out.enableProperty();
  out.reserve(all.size());
  for (const auto& c : all) out.push_back(c.centroid, c.label, 0.0f, 0.0, c.property_mean);
  return out;
}

AxisAlignedBox GlobalMap::bounds() const {
  const Impl& m = *impl_;
  AxisAlignedBox box;
  for (std::size_t i = 0; i < m.cells.size(); ++i) {
    const Cell& c = m.cells.valueAt(i);
    const Eigen::Vector3d origin = unpackKey(m.cells.keyAt(i)).cast<double>() * m.voxel;
    box.extend((origin + (c.offset_sum / float(c.count)).cast<double>()).cast<float>());
  }
  return box;
}

}  // namespace hazmap
