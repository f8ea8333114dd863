#pragma once
// Cooperative yielding: long computations (an ICP's iterations, a loop's verifications) call
// yieldPoint() between their steps. A thread that has something more urgent to give way to (the
// asynchronous back end gives way to tracking, issue 33) installs a hook for its own thread with
// ScopedYieldHook; the hook may block there until the urgent work is done. On every other thread
// yieldPoint() is one thread-local read. A hook must not be installed where a yield point may be
// reached while holding a lock the urgent work needs.
#include <functional>

namespace hazmap {

void yieldPoint();

/// Installs `hook` for the calling thread while it lives (the previous one is restored after).
class ScopedYieldHook {
 public:
  explicit ScopedYieldHook(std::function<void()> hook);
  ~ScopedYieldHook();
  ScopedYieldHook(const ScopedYieldHook&) = delete;
  ScopedYieldHook& operator=(const ScopedYieldHook&) = delete;

 private:
  std::function<void()> hook_;
  const std::function<void()>* previous_;
};

}  // namespace hazmap
