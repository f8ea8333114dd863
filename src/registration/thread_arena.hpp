#pragma once
// RegistrationConfig::threads: run the work in an arena of that many threads (0 = the caller's).
#include <tbb/task_arena.h>

namespace hazmap::detail {

template <typename F>
void runWithThreads(int threads, F&& f) {
  if (threads > 0) {
    tbb::task_arena arena(threads);
    arena.execute(f);
  } else {
    f();
  }
}

}  // namespace hazmap::detail
