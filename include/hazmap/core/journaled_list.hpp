#pragma once
// A per-frame list of a long mission that keeps only its newest entries in memory (issue 33): from
// keepNewest(n) on, the older ones are appended to a journal file (core/journal_file.hpp) and read
// back by index when asked for, exactly as they were (every double's bits). Until then it is a plain
// list. Entries are fixed-size: JournalCodec<T> says how many doubles one takes.
#include <Eigen/Geometry>
#include <algorithm>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "hazmap/core/journal_file.hpp"
#include "hazmap/core/retire_oldest.hpp"
#include "hazmap/core/se3.hpp"

namespace hazmap {

/// How an entry is written to a journal: `kDoubles` doubles, `put` and `get` exact inverses.
template <typename T>
struct JournalCodec;

template <>
struct JournalCodec<double> {
  static constexpr std::size_t kDoubles = 1;
  static void put(double v, double* d) { *d = v; }
  static double get(const double* d) { return *d; }
};

template <>
struct JournalCodec<Eigen::Isometry3d> {
  static constexpr std::size_t kDoubles = 16;
  static void put(const Eigen::Isometry3d& v, double* d) { std::copy_n(v.matrix().data(), kDoubles, d); }
  static Eigen::Isometry3d get(const double* d) {
    Eigen::Isometry3d v;
    std::copy_n(d, kDoubles, v.matrix().data());
    return v;
  }
};

template <>
struct JournalCodec<Matrix6d> {
  static constexpr std::size_t kDoubles = 36;
  static void put(const Matrix6d& v, double* d) { std::copy_n(v.data(), kDoubles, d); }
  static Matrix6d get(const double* d) {
    Matrix6d v;
    std::copy_n(d, kDoubles, v.data());
    return v;
  }
};

template <typename T>
class JournaledList {
  using Codec = JournalCodec<T>;
  static constexpr std::size_t kEntryBytes = Codec::kDoubles * sizeof(double);

 public:
  /// `what` names the journal in its errors.
  explicit JournaledList(std::string what) : what_(std::move(what)) {}

  /// From now on only the newest `keep` entries (at least one) stay in memory. Opens the journal
  /// (in TMPDIR) the first time: throws hazmap::Error when it cannot.
  void keepNewest(std::size_t keep) {
    if (!journal_) journal_ = std::make_unique<JournalFile>(what_);
    keep_ = std::max<std::size_t>(keep, 1);
    retire();
  }
  std::size_t size() const { return first_ + newest_.size(); }
  bool empty() const { return size() == 0; }
  /// Entries firstInMemory() … size() − 1 are in memory (all of them until keepNewest()).
  std::size_t firstInMemory() const { return first_; }

  void push_back(const T& v) {
    newest_.push_back(v);
    if (keep_ > 0) retire();
  }
  T& back() { return newest_.back(); }
  const T& back() const { return newest_.back(); }
  /// Entry k, in memory: std::out_of_range for one in the journal.
  T& operator[](std::size_t k) { return newest_.at(k - first_); }
  const T& operator[](std::size_t k) const { return newest_.at(k - first_); }
  /// Entry k wherever it is.
  T at(std::size_t k) const {
    if (k >= first_) return newest_.at(k - first_);
    double d[Codec::kDoubles];
    journal_->read(k * kEntryBytes, d, kEntryBytes);
    return Codec::get(d);
  }
  /// Reads entries in ascending order of k, the journal a block at a time (a chain over many frames).
  class Cursor {
   public:
    explicit Cursor(const JournaledList& list) : list_(list) {}
    const T& operator()(std::size_t k) {
      if (k >= list_.first_) return list_.newest_.at(k - list_.first_);
      if (k < block_first_ || k - block_first_ >= block_.size()) load(k);
      return block_[k - block_first_];
    }

   private:
    void load(std::size_t k) {
      constexpr std::size_t kBlock = 4096;
      const std::size_t n = std::min(kBlock, list_.first_ - k);
      std::vector<double> raw(n * Codec::kDoubles);
      list_.journal_->read(k * kEntryBytes, raw.data(), n * kEntryBytes);
      block_.clear();
      for (std::size_t i = 0; i < n; ++i) block_.push_back(Codec::get(raw.data() + i * Codec::kDoubles));
      block_first_ = k;
    }
    const JournaledList& list_;
    std::vector<T> block_;
    std::size_t block_first_ = 0;
  };
  /// Every entry, the journal's read back first.
  std::vector<T> all() const {
    std::vector<T> out;
    out.reserve(size());
    Cursor entry(*this);
    for (std::size_t k = 0; k < size(); ++k) out.push_back(entry(k));
    return out;
  }

 private:
  void retire() {
    std::vector<double> bytes;
    first_ += retireOldest(newest_, keep_, [&](const T& v) {
      bytes.resize(bytes.size() + Codec::kDoubles);
      Codec::put(v, bytes.data() + bytes.size() - Codec::kDoubles);
    });
    if (!bytes.empty()) journal_->append(bytes.data(), bytes.size() * sizeof(double));
  }

  std::string what_;
  std::vector<T> newest_;  // entries first_ … size() − 1
  std::size_t first_ = 0;
  std::size_t keep_ = 0;  // 0: everything in memory
  std::unique_ptr<JournalFile> journal_;
};

}  // namespace hazmap
