#pragma once
// The run's frame records as the graph's side reads them (SlamResult::frames): a view of that list
// (a run on the tracker's thread), or on the back end's own thread the newest records in it and
// the older ones appended to a journal file (issue 33: a record is ~0.9 kB, ~30 MB an hour at 10
// scans/s, and only a save reads the old ones), read back whole for a save.
#include <cstdint>
#include <memory>
#include <vector>

#include "hazmap/core/journal_file.hpp"
#include "hazmap/pipeline/slam.hpp"

namespace hazmap::pipeline_detail {

class FrameRecordStore {
 public:
  explicit FrameRecordStore(std::vector<FrameRecord>& frames) : frames_(frames) {}

  /// From now on only the newest `keep` records (at least one) stay in the list; the older ones go
  /// to a file in the temporary folder (TMPDIR), unlinked at once.
  void journalOlderThan(std::size_t keep);
  std::size_t size() const { return first_ + frames_.size(); }
  void push(FrameRecord record);
  /// Record k in the list (std::out_of_range for one in the journal).
  FrameRecord& at(std::size_t k) { return frames_.at(k - first_); }
  const FrameRecord& at(std::size_t k) const { return frames_.at(k - first_); }
  const FrameRecord& back() const { return frames_.back(); }
  /// Record k wherever it is.
  FrameRecord read(std::size_t k) const;
  /// Every record, the journal's read back before the list's.
  std::vector<FrameRecord> all() const;
  /// The list holds every record again (the end of a run: its result is read whole).
  void restoreAll();

 private:
  void journalBeyond(std::size_t keep);  // the records older than the newest `keep` into the journal

  std::vector<FrameRecord>& frames_;  // records first_ … size() − 1
  std::size_t first_ = 0;
  std::size_t keep_ = 0;  // 0: no journal
  std::unique_ptr<JournalFile> journal_;
  std::vector<std::uint64_t> offsets_;  // record k's place in the journal, k < first_
};

}  // namespace hazmap::pipeline_detail
