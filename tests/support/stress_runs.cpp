#include "stress_runs.hpp"

#include <algorithm>
#include <chrono>

namespace hazmap::stress {
namespace {
using Clock = std::chrono::steady_clock;
double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
}  // namespace

double TrackRun::meanMs() const {
  double sum = 0.0;
  for (double m : ms) sum += m;
  return ms.empty() ? 0.0 : sum / static_cast<double>(ms.size());
}

double TrackRun::worstOverMedian() const {
  std::vector<double> kept;
  for (std::size_t i = 1; i < ms.size(); ++i)  // the first scan registers nothing
    if (!lost[i]) kept.push_back(ms[i]);
  if (kept.size() < 2) return 1.0;
  const double worst = *std::max_element(kept.begin(), kept.end());
  std::nth_element(kept.begin(), kept.begin() + kept.size() / 2, kept.end());
  return worst / kept[kept.size() / 2];
}

TrackRun runHazmap(const Sequence& seq, const ClassTable& table, const OdometryConfig& config) {
  TrackRun run;
  Odometry odo(table, config);
  for (const LabeledCloud& scan : seq.scans) {
    const auto t = Clock::now();
    const OdometryFrame& f = odo.addFrame(scan);
    run.ms.push_back(msSince(t));
    run.lost.push_back(f.status == FrameStatus::Fallback);
    run.notes.push_back(std::string(toString(f.status)) + (f.guess_hypothesis.empty() ? "" : ", from " + f.guess_hypothesis));
    run.searches.push_back(f.searches);
    run.recovered.push_back(!f.global.trigger.empty());
    run.details.push_back(f.global.trigger.empty() ? "" : f.global.trigger + " -> " + f.global.outcome + " (" +
                                                              std::to_string(static_cast<int>(f.global.milliseconds)) + " ms)");
  }
  for (const OdometryFrame& f : odo.frames()) run.poses.push_back(f.pose);  // final values (lost frames re-estimated)
  return run;
}

TrackRun runKiss(const Sequence& seq, const baseline::KissIcpConfig& config) {
  TrackRun run;
  baseline::KissIcp kiss(config);
  for (const LabeledCloud& scan : seq.scans) {
    const auto t = Clock::now();
    run.poses.push_back(kiss.addFrame(scan));
    run.ms.push_back(msSince(t));
    run.lost.push_back(0);
    run.notes.push_back("");
    run.details.push_back("");
  }
  return run;
}

}  // namespace hazmap::stress
