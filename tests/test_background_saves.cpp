// hazmap live's saves while running (apps/background_saves.hpp): the pipeline's thread hands a
// snapshot over and goes on; one save writes at a time; the newest snapshot waiting wins; the end
// waits for what is queued, so nothing is lost before the final write.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "../apps/background_saves.hpp"

namespace {

using hazmap::cli::BackgroundSaves;

/// A save that holds until released, recording what it wrote.
struct GatedWrites {
  std::mutex m;
  std::condition_variable cv;
  bool open = false;
  int started = 0;
  std::vector<int> written;

  void write(int job) {
    std::unique_lock<std::mutex> lock(m);
    ++started;
    cv.notify_all();
    cv.wait(lock, [&] { return open; });
    written.push_back(job);
  }
  void waitStarted(int n) {
    std::unique_lock<std::mutex> lock(m);
    ASSERT_TRUE(cv.wait_for(lock, std::chrono::seconds(10), [&] { return started >= n; }));
  }
  void release() {
    {
      std::lock_guard<std::mutex> lock(m);
      open = true;
    }
    cv.notify_all();
  }
};

TEST(BackgroundSaves, SubmitReturnsWhileTheSaveWrites) {
  GatedWrites gate;
  BackgroundSaves<int> saves([&](int& job) { gate.write(job); });
  EXPECT_FALSE(saves.busy());
  saves.submit(1);  // returns although the save cannot end yet
  gate.waitStarted(1);
  EXPECT_TRUE(saves.busy());
  gate.release();
  saves.finish();
  EXPECT_FALSE(saves.busy());
  EXPECT_EQ(gate.written, std::vector<int>{1});
}

TEST(BackgroundSaves, TheNewestSnapshotWaitingReplacesOlderOnes) {
  GatedWrites gate;
  BackgroundSaves<int> saves([&](int& job) { gate.write(job); });
  saves.submit(1);
  gate.waitStarted(1);
  saves.submit(2);
  saves.submit(3);  // 2 never started: 3 is newer
  EXPECT_TRUE(saves.busy());
  gate.release();
  saves.finish();
  EXPECT_EQ(gate.written, (std::vector<int>{1, 3}));
}

TEST(BackgroundSaves, FinishWritesWhatIsQueuedBeforeItReturns) {
  std::vector<int> written;
  {
    BackgroundSaves<int> saves([&](int& job) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      written.push_back(job);
    });
    saves.submit(7);
    saves.finish();
    EXPECT_EQ(written, std::vector<int>{7});
    saves.finish();  // a second call (and the destructor) is harmless
  }
  EXPECT_EQ(written, std::vector<int>{7});
}

TEST(BackgroundSaves, TheIntervalCountsFromTheEndOfTheLastSave) {
  BackgroundSaves<int> saves([](int&) { std::this_thread::sleep_for(std::chrono::milliseconds(30)); });
  const auto before = saves.lastEnded();
  const auto submitted = std::chrono::steady_clock::now();
  saves.submit(1);
  saves.finish();
  EXPECT_GT(saves.lastEnded(), before);
  EXPECT_GE(saves.lastEnded() - submitted, std::chrono::milliseconds(30));
}

}  // namespace
