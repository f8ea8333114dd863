#include "pipeline/back_end_thread.hpp"

#include <sched.h>
#include <sys/resource.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include "hazmap/core/yield_point.hpp"

namespace hazmap::pipeline_detail {

namespace {

using SteadyClock = std::chrono::steady_clock;

// On a machine whose cores are all busy the back end yields to tracking (and to the receive
// thread): tracking is what the sensor's rate waits for, the back end only has to keep up on
// average. So it runs only on a core nothing else wants (SCHED_IDLE): a tracking thread that wakes
// takes the core at once, where at nice 10 it waited for the scheduler's granularity, and tracking
// as fast as it goes kept 0.56–0.73 of its rate alone (bench_async_back_end, 2026-12-05). Where
// that policy is refused, nice 10. It runs its loop stage on its own thread alone (an arena of
// one: TBB's workers stay with tracking); the loop stage's results do not depend on the thread count.
constexpr int kBackEndNice = 10;

// Even on a core of its own the back end slows tracking: two busy vCPUs share caches and memory
// bandwidth (here tracking on one thread took 6.7–6.9 ms a scan alone and 7.8–8.0 beside a busy
// back end, docs/live.md). So it works only while tracking waits for the sensor: at its yield points
// (an ICP iteration, a candidate, a submap's keyframe, a loop stage's start) it pauses while tracking
// has a scan in hand, and until tracking has waited kInputGrace for the next one (a source with the
// next scan at hand, a recording or a stream tracking is catching up on, hands it over sooner, and
// then tracking goes on alone). A back end this far behind (the frame in hand queued that long ago:
// tracking has had scans waiting for seconds) stops giving way and shares the cores as before, so
// its corrections come at most this much later.
constexpr auto kMaxYieldLag = std::chrono::seconds(5);
constexpr auto kInputGrace = std::chrono::milliseconds(2);

void yieldToTracking() {
  const sched_param none{};
  if (::sched_setscheduler(0, SCHED_IDLE, &none) != 0) ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), kBackEndNice);
}

// A back end kMaxYieldLag behind also leaves SCHED_IDLE: on a machine another process keeps busy
// an idle-class thread gets next to no CPU (beside two busy loops on the 2 cores: 0.3 % of one, so
// a 110-frame live test took 156 s instead of 8 and its corrections came after the last frame), and
// "shares the cores" has to hold against other processes too. Back to SCHED_IDLE once caught up.
void shareCores() {
  const sched_param none{};
  if (::sched_setscheduler(0, SCHED_OTHER, &none) == 0) ::setpriority(PRIO_PROCESS, static_cast<id_t>(::gettid()), 0);
}

template <typename T>
std::size_t bytesOf(const std::vector<T>& v) {
  return v.size() * sizeof(T);
}

std::size_t queuedBytes(const TrackedFrame& f) {
  const LabeledCloud& c = f.cloud;
  return bytesOf(c.points) + bytesOf(c.classes) + bytesOf(c.intensity) + bytesOf(c.timestamps) + bytesOf(c.property);
}

}  // namespace

BackEndThread::BackEndThread(const SlamConfig& config, const Eigen::Isometry3d& start, const ClassTable& classes,
                             ScanSource& source, std::mutex& source_lock,
                             std::function<void(std::size_t)> before_loop_stage)
    : config_(config), graph_(config, result_, tracked_, start), before_loop_stage_(std::move(before_loop_stage)) {
  result_.method = config.method;
  result_.graph.dimension = 3;
  graph_.start(classes, source, &source_lock);
  // Only a save reads the old records (and the map anchors old keyframes' tracked poses, the gate
  // a chain of step covariances); re-estimation rewrites at most reestimationReach() back (twice
  // that kept: a margin, not a bound anything relies on).
  const std::size_t keep = 2 * reestimationReach(config.odometry.recovery);
  graph_.journalOlderThan(keep);
  tracked_.keepNewest(keep);
  thread_ = std::thread([this] { run(); });
}

BackEndThread::~BackEndThread() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
    queue_.clear();  // not finished (an error on the tracker's side): what is queued is dropped
  }
  releaseTurn(SteadyClock::time_point{});
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void BackEndThread::trackingBegins() { tracking_.store(true, std::memory_order_release); }

void BackEndThread::trackingWaits() { releaseTurn(SteadyClock::now()); }

void BackEndThread::releaseTurn(SteadyClock::time_point waiting_since) {
  {
    std::lock_guard<std::mutex> lock(turn_m_);
    waiting_since_.store(waiting_since.time_since_epoch().count(), std::memory_order_relaxed);
    tracking_.store(false, std::memory_order_release);
  }
  turn_over_.notify_all();
}

SteadyClock::time_point BackEndThread::waitingSince() const {
  return SteadyClock::time_point{SteadyClock::duration(waiting_since_.load(std::memory_order_relaxed))};
}

// The back end's turn: tracking waits for input, and has for kInputGrace.
bool BackEndThread::backEndsTurn(SteadyClock::time_point now) const {
  return !tracking_.load(std::memory_order_acquire) && now - waitingSince() >= kInputGrace;
}

// Back end's thread: out of SCHED_IDLE while the frame in hand was queued kMaxYieldLag ago or more.
void BackEndThread::keepUp(SteadyClock::time_point now) {
  const bool behind = now - applying_queued_at_ >= kMaxYieldLag;
  if (behind == sharing_cores_) return;
  behind ? shareCores() : yieldToTracking();
  sharing_cores_ = behind;
}

// The back end's yield points: wait for its turn, for at most what is left of kMaxYieldLag since
// the frame in hand was queued.
void BackEndThread::giveWayToTracking() {
  const SteadyClock::time_point now = SteadyClock::now();
  keepUp(now);
  if (backEndsTurn(now)) return;
  const SteadyClock::time_point patience = applying_queued_at_ + kMaxYieldLag;
  std::unique_lock<std::mutex> lock(turn_m_);
  for (SteadyClock::time_point now = SteadyClock::now(); !backEndsTurn(now) && now < patience; now = SteadyClock::now()) {
    const bool waits = !tracking_.load(std::memory_order_acquire);
    turn_over_.wait_until(lock, waits ? std::min(waitingSince() + kInputGrace, patience) : patience);
  }
}

void BackEndThread::push(TrackedFrame frame) {
  frame.queued_at = SteadyClock::now();
  const std::size_t bytes = queuedBytes(frame);
  const double limit = config_.back_end_queue_mb * 1024.0 * 1024.0;
  {
    std::unique_lock<std::mutex> lock(m_);
    const auto room = [&] { return failure_ || queued_bytes_ == 0 || double(queued_bytes_ + bytes) <= limit; };
    if (!room()) {
      releaseTurn(SteadyClock::time_point{});  // tracking waits for the back end now
      room_.wait(lock, room);
    }
    rethrow();
    queued_bytes_ += bytes;
    queue_.push_back(std::move(frame));
    ++frames_queued_;
  }
  wake_.notify_one();
}

std::shared_ptr<const std::vector<Eigen::Isometry3d>> BackEndThread::takeSolution() {
  std::lock_guard<std::mutex> lock(m_);
  return std::move(solution_);
}

void BackEndThread::snapshotOfQueued(std::function<void(SlamResult)> deliver) {
  {
    std::lock_guard<std::mutex> lock(m_);
    rethrow();
    snapshots_.push_back({frames_queued_, std::move(deliver)});
  }
  wake_.notify_one();
}

// Between two frames on the back end's thread: nothing writes the result meanwhile.
SlamResult BackEndThread::copyOfResult() {
  SlamResult s = result_;
  s.frames = graph_.records().all();
  s.graph.edges = graph_.allEdges();
  graph_.describeLoopsSoFar(s);
  return s;
}

// Back end's thread, `m_` held.
bool BackEndThread::snapshotDue() const { return !snapshots_.empty() && snapshots_.front().frames <= frames_applied_; }

// The front snapshot request, copied and delivered outside the lock (`m_` held on entry and exit).
void BackEndThread::deliverSnapshot(std::unique_lock<std::mutex>& lock) {
  SnapshotRequest request = std::move(snapshots_.front());
  snapshots_.pop_front();
  delivering_ = true;
  lock.unlock();
  std::exception_ptr failure;
  // Out of SCHED_IDLE while delivering: the consumer's hand-over ends with the run's "snapshot
  // pending" cleared, and a consumer that lets tracking go on inside it (a source waiting for the
  // snapshot) must not find the next one still pending because this thread, idle-class, got no
  // core again for seconds (LiveSaveMap.ASavesMapAfterLoopCorrections…, a snapshot short under ctest -j2).
  if (!sharing_cores_) shareCores();
  try {
    request.deliver(copyOfResult());
  } catch (...) {
    failure = std::current_exception();
  }
  if (!sharing_cores_) yieldToTracking();
  lock.lock();
  delivering_ = false;
  if (failure) failure_ = failure;
}

SlamResult BackEndThread::finish() {
  {
    std::unique_lock<std::mutex> lock(m_);
    waitIdle(lock);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
  rethrow();
  graph_.records().restoreAll();
  graph_.finish();
  return std::move(result_);
}

void BackEndThread::waitIdle(std::unique_lock<std::mutex>& lock) {
  releaseTurn(SteadyClock::time_point{});
  idle_.wait(lock, [&] { return failure_ || (queue_.empty() && !busy_ && !delivering_ && snapshots_.empty()); });
}

void BackEndThread::rethrow() {
  if (failure_) std::rethrow_exception(failure_);
}

std::size_t BackEndThread::backlog() {
  std::lock_guard<std::mutex> lock(m_);
  return queue_.size() + (busy_ ? 1 : 0);
}

void BackEndThread::run() {
  yieldToTracking();
  const ScopedYieldHook give_way([this] { giveWayToTracking(); });
  tbb::task_arena alone(1);
  alone.execute([this] {
    for (;;) {
      TrackedFrame frame;
      {
        std::unique_lock<std::mutex> lock(m_);
        wake_.wait(lock, [&] { return stop_ || !queue_.empty() || snapshotDue(); });
        if (snapshotDue()) {
          deliverSnapshot(lock);
          const bool failed = failure_ != nullptr;
          lock.unlock();
          idle_.notify_all();
          if (failed) return;
          continue;
        }
        if (queue_.empty()) return;
        frame = std::move(queue_.front());
        queue_.pop_front();
        busy_ = true;
      }
      const std::size_t bytes = queuedBytes(frame);
      applying_queued_at_ = frame.queued_at;
      keepUp(SteadyClock::now());
      std::exception_ptr failure;
      try {
        apply(frame);
        ++frames_applied_;
      } catch (...) {
        failure = std::current_exception();
      }
      std::shared_ptr<const std::vector<Eigen::Isometry3d>> solution;
      if (result_.optimisations.size() != optimisations_published_) {
        optimisations_published_ = result_.optimisations.size();
        solution = std::make_shared<const std::vector<Eigen::Isometry3d>>(result_.graph.poses);
      }
      {
        std::lock_guard<std::mutex> lock(m_);
        queued_bytes_ -= bytes;
        busy_ = false;
        if (solution) solution_ = std::move(solution);
        if (failure) failure_ = failure;
      }
      idle_.notify_all();
      room_.notify_all();
      if (failure) return;
    }
  });
}

// The synchronous schedule's order for one frame (slam.cpp SlamRun::addScan): node and edge,
// record, re-estimated frames, then a keyframe's gravity prior and loop stage.
void BackEndThread::apply(TrackedFrame& f) {
  tracked_.push_back(f.tracked_pose);
  graph_.addFrame(f.record);
  graph_.records().push(std::move(f.record));
  if (!f.reestimated.empty()) {
    std::vector<std::size_t> changed;
    for (FrameRecord& r : f.reestimated) {
      changed.push_back(r.index);
      graph_.records().at(r.index) = std::move(r);
    }
    chainFrom(tracked_, graph_.records(), changed.front());
    graph_.replaceFrames(changed);
  }
  if (!f.keyframe) return;
  graph_.addGravityPrior(f.gravity);
  yieldPoint();  // a loop stage starts only on the back end's turn
  if (before_loop_stage_) before_loop_stage_(graph_.records().size() - 1);
  graph_.closeLoops(std::move(f.cloud));
}

}  // namespace hazmap::pipeline_detail
