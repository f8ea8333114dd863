#pragma once
// Scans cut from a packet stream (a capture's or a live sensor's), waiting to be handed on with
// the IMU samples over their span: the common tail of both sources' next().
#include <cstddef>
#include <deque>
#include <optional>

#include "hazmap/sources/scan_source.hpp"
#include "sources/imu_attach.hpp"
#include "sources/scan_assembler.hpp"

namespace hazmap::sources {

class AssembledScans {
 public:
  /// Where the assembler appends the scans it completes.
  std::deque<RawScan>& pending() { return pending_; }
  ImuBuffer& imu() { return imu_; }
  bool empty() const { return pending_.empty(); }
  /// Whether the oldest scan can go: with an IMU stream, once samples past its last point have
  /// arrived (or the next scan has).
  bool ready() const;
  /// The oldest scan: numbered in order, classes none, Scan::imu over its span.
  Scan pop();

 private:
  std::deque<RawScan> pending_;
  ImuBuffer imu_;
  std::size_t next_index_ = 0;
  std::optional<double> previous_stamp_;
};

}  // namespace hazmap::sources
