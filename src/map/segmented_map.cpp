#include "hazmap/map/segmented_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>

#include "hazmap/core/error.hpp"

namespace hazmap {

struct SegmentedMap::Segment {
  std::size_t first = 0, count = 0;   // frames first … first + count − 1
  Eigen::Isometry3d anchor_then;       // the first frame's pose when its scan was inserted
  GlobalMap map;                       // the scans at their poses then
  // Placement relative to the previous segment at the last compose (the composer's only).
  std::optional<Eigen::Isometry3d> relative_seen;

  Segment(std::size_t first_frame, const Eigen::Isometry3d& anchor, const GlobalMapConfig& c, const ClassTable& t)
      : first(first_frame), anchor_then(anchor), map(c, t) {}
  std::size_t end() const { return first + count; }
};

namespace {

/// How far `b` is from `a`: translation (m) and rotation angle (rad) of a⁻¹·b.
std::pair<double, double> difference(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const Eigen::Isometry3d d = a.inverse() * b;
  return {d.translation().norm(), Eigen::AngleAxisd(d.linear()).angle()};
}

/// A segment's move since its scans were inserted: its anchor's pose now · its pose then⁻¹, the
/// identity exactly when the anchor has not moved (then its cells stay as they are).
Eigen::Isometry3d correctionOf(const Eigen::Isometry3d& now, const Eigen::Isometry3d& then) {
  if (now.matrix() == then.matrix()) return Eigen::Isometry3d::Identity();
  return now * then.inverse();
}

}  // namespace

SegmentedMap::SegmentedMap(GlobalMapConfig map, ClassTable table, SegmentedMapConfig config)
    : map_config_(map), table_(std::move(table)), config_(config) {
  map_config_.validate();
  if (config_.max_segments < 2) fail("segmented map", "max_segments must be >= 2");
  if (!(config_.merge_translation >= 0) || !(config_.merge_rotation >= 0))
    fail("segmented map", "merge tolerances must be >= 0");
}

SegmentedMap::~SegmentedMap() = default;

void SegmentedMap::add(std::size_t frame, const LabeledCloud& scan, std::span<const PointChannel> channels,
                       const Eigen::Isometry3d& T_world_sensor, std::size_t anchor,
                       const Eigen::Isometry3d& T_world_anchor_now) {
  if (frame != frames_)
    fail("segmented map", "frame " + std::to_string(frame) + " added after " + std::to_string(frames_) + " frames");
  if (anchor == frame) {
    close();
    open_ = std::make_unique<Segment>(frame, T_world_sensor, map_config_, table_);
    open_->map.insert(frame, scan, T_world_sensor, channels);
  } else {
    if (!open_ || open_->first != anchor)
      fail("segmented map", "frame " + std::to_string(frame) + " given anchor " + std::to_string(anchor) +
                                " but the open segment begins at " + (open_ ? std::to_string(open_->first) : "none"));
    // Where the frame lies relative to the anchor now, in the anchor's coordinates then.
    open_->map.insert(frame, scan, correctionOf(T_world_anchor_now, open_->anchor_then).inverse() * T_world_sensor,
                      channels);
  }
  ++open_->count;
  ++frames_;
}

void SegmentedMap::add(std::size_t frame, const LabeledCloud& scan, std::span<const PointChannel> channels,
                       std::span<const Eigen::Isometry3d> poses_now, std::size_t frames_per_segment) {
  const bool begins = !open_ || open_->count >= std::max<std::size_t>(frames_per_segment, 1);
  const std::size_t anchor = begins ? frame : open_->first;
  if (poses_now.size() <= frame) fail("segmented map", "no pose for frame " + std::to_string(frame));
  add(frame, scan, channels, poses_now[frame], anchor, poses_now[anchor]);
}

void SegmentedMap::close() {
  if (!open_) return;
  std::shared_ptr<Segment> done(std::move(open_));
  std::lock_guard<std::mutex> lock(mutex_);
  closed_.push_back(std::move(done));
}

std::size_t SegmentedMap::frames() const { return frames_; }

std::size_t SegmentedMap::segments() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_.size();
}

std::shared_ptr<SegmentedMap::Segment> SegmentedMap::merged(const std::vector<std::shared_ptr<Segment>>& run,
                                                            std::span<const Eigen::Isometry3d> corrections) const {
  auto m = std::make_shared<Segment>(run.front()->first, run.front()->anchor_then, map_config_, table_);
  // Member j's scans, now at C_j·x, are at C_0⁻¹·C_j·x in the first member's coordinates then.
  const Eigen::Isometry3d to_first = corrections.front().inverse();
  for (std::size_t j = 0; j < run.size(); ++j) {
    const bool alike = corrections[j].matrix() == corrections.front().matrix();
    m->map.insertMap(run[j]->map, alike ? Eigen::Isometry3d::Identity() : to_first * corrections[j]);
    m->count += run[j]->count;
  }
  return m;
}

void SegmentedMap::mergeSteadyNeighbours(std::vector<std::shared_ptr<Segment>>& prefix,
                                         std::span<const Eigen::Isometry3d> poses) const {
  const std::size_t n = prefix.size();
  if (n < 2) return;
  std::vector<Eigen::Isometry3d> correction(n);
  for (std::size_t i = 0; i < n; ++i) correction[i] = correctionOf(poses[prefix[i]->first], prefix[i]->anchor_then);
  // join[i]: segment i joins segment i − 1. Steady: placed alike at this compose and the last.
  std::vector<bool> join(n, false);
  std::vector<double> unsteadiness(n, std::numeric_limits<double>::infinity());
  std::size_t runs = n;
  for (std::size_t i = 1; i < n; ++i) {
    const Eigen::Isometry3d relative = correction[i - 1].inverse() * correction[i];
    if (prefix[i]->relative_seen) {
      const auto [dt, dr] = difference(*prefix[i]->relative_seen, relative);
      unsteadiness[i] = std::max(dt / std::max(config_.merge_translation, 1e-9), dr / std::max(config_.merge_rotation, 1e-9));
      if (dt <= config_.merge_translation && dr <= config_.merge_rotation) {
        join[i] = true;
        --runs;
      }
    }
  }
  // Too many segments: the steadiest remaining neighbours (the oldest first among the unseen).
  while (runs > config_.max_segments) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < n; ++i)
      if (!join[i] && (best == 0 || unsteadiness[i] < unsteadiness[best])) best = i;
    join[best] = true;
    --runs;
  }
  std::vector<std::shared_ptr<Segment>> out;
  std::size_t previous_first = 0;  // where the previous run began in `prefix`
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i + 1;
    while (j < n && join[j]) ++j;
    if (j == i + 1) {
      out.push_back(prefix[i]);
    } else {
      const std::vector<std::shared_ptr<Segment>> run(prefix.begin() + std::ptrdiff_t(i), prefix.begin() + std::ptrdiff_t(j));
      out.push_back(merged(run, std::span(correction).subspan(i, j - i)));
    }
    // Seen from here on relative to the previous run's first member (the merged segment's anchor).
    if (i > 0) out.back()->relative_seen = correction[previous_first].inverse() * correction[i];
    previous_first = i;
    i = j;
  }
  prefix = std::move(out);
}

GlobalMap SegmentedMap::compose(std::size_t frames, std::span<const Eigen::Isometry3d> poses) {
  if (poses.size() < frames)
    fail("segmented map", std::to_string(poses.size()) + " poses for " + std::to_string(frames) + " frames");
  std::vector<std::shared_ptr<Segment>> prefix;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& s : closed_) {
      if (s->first >= frames) break;
      prefix.push_back(s);
    }
  }
  if (frames > 0 && (prefix.empty() || prefix.back()->end() != frames))
    fail("segmented map", "no segment ends at frame " + std::to_string(frames) + " (close() after it)");
  const std::size_t taken = prefix.size();
  mergeSteadyNeighbours(prefix, poses);
  {
    // The adder only appends: the first `taken` segments are still the ones read above.
    std::lock_guard<std::mutex> lock(mutex_);
    closed_.erase(closed_.begin(), closed_.begin() + std::ptrdiff_t(taken));
    closed_.insert(closed_.begin(), prefix.begin(), prefix.end());
  }
  GlobalMap world(map_config_, table_);
  for (const auto& s : prefix) world.insertMap(s->map, correctionOf(poses[s->first], s->anchor_then));
  return world;
}

}  // namespace hazmap
