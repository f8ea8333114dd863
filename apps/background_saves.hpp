#pragma once
// hazmap live's saves while running, off the pipeline's thread. A save re-reads the whole spool
// (the map's second pass), so its cost grows with the mission: on the pipeline's thread it held
// tracking for seconds once the mission was long (docs/live.md). The pipeline hands a snapshot
// here and goes on; one save runs at a time, and the pipeline takes no new snapshot while one is
// running (a snapshot copies the whole result).
#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

namespace hazmap::cli {

template <class Job>
class BackgroundSaves {
 public:
  /// `write` runs on the saver's thread, one job at a time; it must not throw.
  explicit BackgroundSaves(std::function<void(Job&)> write) : write_(std::move(write)), thread_([this] { loop(); }) {}
  ~BackgroundSaves() { finish(); }
  BackgroundSaves(const BackgroundSaves&) = delete;
  BackgroundSaves& operator=(const BackgroundSaves&) = delete;

  /// True while a save is queued or writing (the pipeline then takes no snapshot).
  bool busy() const {
    std::lock_guard<std::mutex> lock(m_);
    return job_.has_value() || writing_;
  }
  /// When the last save ended (or the saver started): the autosave interval counts from there,
  /// so a save that takes longer than the interval does not run back to back.
  std::chrono::steady_clock::time_point lastEnded() const {
    std::lock_guard<std::mutex> lock(m_);
    return last_ended_;
  }
  void submit(Job job) {
    {
      std::lock_guard<std::mutex> lock(m_);
      job_ = std::move(job);
    }
    wake_.notify_all();
  }
  /// Lets a queued or running save end, then stops the thread (before the final write: two
  /// writers must never share the run folder).
  void finish() {
    {
      std::lock_guard<std::mutex> lock(m_);
      if (stopping_) return;
      stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(m_);
    while (true) {
      wake_.wait(lock, [&] { return job_.has_value() || stopping_; });
      if (!job_) return;  // stopping, nothing queued
      Job job = std::move(*job_);
      job_.reset();
      writing_ = true;
      lock.unlock();
      write_(job);
      lock.lock();
      writing_ = false;
      last_ended_ = std::chrono::steady_clock::now();
    }
  }

  std::function<void(Job&)> write_;
  mutable std::mutex m_;
  std::condition_variable wake_;
  std::optional<Job> job_;
  bool writing_ = false, stopping_ = false;
  std::chrono::steady_clock::time_point last_ended_ = std::chrono::steady_clock::now();
  std::thread thread_;  // last: started once everything above is constructed
};

}  // namespace hazmap::cli
