#pragma once
// A one-line progress bar for long runs: frames done, frames/s and ETA, redrawn in place on a
// terminal and silent when stderr is piped or redirected (CI logs stay clean).
#include <chrono>
#include <cstddef>
#include <string>

namespace hazmap {

class ProgressBar {
 public:
  /// `total` = 0: unknown (a stream), frames and rate only. `enabled` < 0 → on exactly when
  /// stderr is a terminal.
  ProgressBar(std::string label, std::size_t total, int enabled = -1);
  ~ProgressBar();
  void update(std::size_t done);
  void finish();
  bool enabled() const { return enabled_; }

 private:
  std::string label_;
  std::size_t total_;
  bool enabled_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_, last_draw_;
};

}  // namespace hazmap
