#include "pipeline/frame_record_store.hpp"

#include <algorithm>
#include <string>

#include "hazmap/core/error.hpp"
#include "hazmap/core/retire_oldest.hpp"
#include "sources/byte_cursor.hpp"

namespace hazmap::pipeline_detail {

namespace {

constexpr const char* kWhere = "frame record journal";

// A record as bytes: every field, doubles as they are (the journal is this process's own, read back
// by the same binary), the reason as its length and characters.
class Writer {
 public:
  template <typename T>
  void put(const T& v) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(&v);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void putDoubles(const double* d, std::size_t n) {
    const auto* p = reinterpret_cast<const std::uint8_t*>(d);
    bytes_.insert(bytes_.end(), p, p + n * sizeof(double));
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

void readDoubles(sources::ByteCursor& in, double* d, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) d[i] = in.read<double>();
}

std::vector<std::uint8_t> encode(const FrameRecord& r) {
  Writer w;
  w.put(static_cast<std::uint64_t>(r.index));
  w.put(r.stamp);
  w.putDoubles(r.T_prev_curr.matrix().data(), 16);
  w.putDoubles(r.covariance.data(), 36);
  w.put(static_cast<std::uint8_t>(r.icp_used));
  w.put(static_cast<std::int32_t>(r.status));
  w.put(static_cast<std::uint64_t>(r.fallback_reason.size()));
  for (char c : r.fallback_reason) w.put(c);
  w.put(r.fitness);
  w.put(r.rmse);
  w.put(static_cast<std::int32_t>(r.iterations));
  w.put(static_cast<std::uint8_t>(r.stalled));
  w.put(r.milliseconds);
  w.put(static_cast<std::uint64_t>(r.points));
  w.put(static_cast<std::uint8_t>(r.deskew_velocity.has_value()));
  if (r.deskew_velocity) w.putDoubles(r.deskew_velocity->data(), 6);
  w.putDoubles(r.guess_covariance.data(), 36);
  return w.bytes();
}

FrameRecord decode(sources::ByteCursor& in) {
  FrameRecord r;
  r.index = static_cast<std::size_t>(in.read<std::uint64_t>());
  r.stamp = in.read<double>();
  readDoubles(in, r.T_prev_curr.matrix().data(), 16);
  readDoubles(in, r.covariance.data(), 36);
  r.icp_used = in.read<std::uint8_t>() != 0;
  r.status = static_cast<FrameStatus>(in.read<std::int32_t>());
  const auto reason = in.bytes(in.read<std::uint64_t>(), "reason");
  r.fallback_reason.assign(reinterpret_cast<const char*>(reason.data()), reason.size());
  r.fitness = in.read<double>();
  r.rmse = in.read<double>();
  r.iterations = in.read<std::int32_t>();
  r.stalled = in.read<std::uint8_t>() != 0;
  r.milliseconds = in.read<double>();
  r.points = static_cast<std::size_t>(in.read<std::uint64_t>());
  if (in.read<std::uint8_t>() != 0) {
    Vector6d v;
    readDoubles(in, v.data(), 6);
    r.deskew_velocity = v;
  }
  readDoubles(in, r.guess_covariance.data(), 36);
  return r;
}

}  // namespace

void FrameRecordStore::journalOlderThan(std::size_t keep) {
  if (!journal_) journal_ = std::make_unique<JournalFile>(kWhere);  // first: a store whose journal failed stays as it was
  keep_ = std::max<std::size_t>(keep, 1);
  journalBeyond(keep_);
}

void FrameRecordStore::push(FrameRecord record) {
  frames_.push_back(std::move(record));
  if (keep_ > 0) journalBeyond(keep_);
}

void FrameRecordStore::journalBeyond(std::size_t keep) {
  first_ += retireOldest(frames_, keep, [&](const FrameRecord& r) {
    const std::vector<std::uint8_t> bytes = encode(r);
    offsets_.push_back(journal_->append(bytes.data(), bytes.size()));
  });
}

// Record k's bytes run from its offset to the next record's (or the journal's end).
FrameRecord FrameRecordStore::read(std::size_t k) const {
  if (k >= first_) return frames_.at(k - first_);
  const std::uint64_t end = k + 1 < offsets_.size() ? offsets_[k + 1] : journal_->size();
  std::vector<std::uint8_t> bytes(end - offsets_.at(k));
  journal_->read(offsets_[k], bytes.data(), bytes.size());
  sources::ByteCursor in(bytes, std::string(kWhere) + " record " + std::to_string(k));
  return decode(in);
}

std::vector<FrameRecord> FrameRecordStore::all() const {
  std::vector<FrameRecord> out;
  out.reserve(size());
  for (std::size_t k = 0; k < first_; ++k) out.push_back(read(k));
  out.insert(out.end(), frames_.begin(), frames_.end());
  return out;
}

void FrameRecordStore::restoreAll() {
  if (first_ == 0) return;
  frames_ = all();
  first_ = 0;
  offsets_.clear();
  keep_ = 0;
  journal_.reset();
}

}  // namespace hazmap::pipeline_detail
