// Per-step view of the tracking stress cases (issue 35): for each case, each step's error against
// the reference, hazmap's frame status and the hypothesis it started from, beside the KISS-ICP
// reimplementation's error. Usage: tracking_stress_steps DATA_DIR [yaw_deg ...]
// (default 10 20 30 45 60 90; sudden yaw at KITTI scan 3 and Ouster scan 1).
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "hazmap/core/memory.hpp"
#include "stress_runs.hpp"

using namespace hazmap;

static void show(const stress::Sequence& seq) {
  const stress::TrackRun h = stress::runHazmap(seq, ClassTable::semanticKitti(), OdometryConfig{});
  const stress::TrackRun k = stress::runKiss(seq);
  const auto eh = stress::stepErrors(seq, h.poses), ek = stress::stepErrors(seq, k.poses);
  std::printf("%s (%.0f / %.0f ms per scan hazmap / KISS reimpl.)\n", seq.name.c_str(), h.meanMs(), k.meanMs());
  for (std::size_t i = 0; i < eh.size(); ++i)
    std::printf("  step %zu turns %5.1f deg: hazmap %6.3f m %6.3f deg %7.0f ms [%s] | KISS %6.3f m %6.3f deg\n", i + 1,
                eh[i].reference_yaw_deg, eh[i].translation, eh[i].rotation_deg, h.ms[i + 1], h.notes[i + 1].c_str(),
                ek[i].translation, ek[i].rotation_deg);
  for (std::size_t i = 1; i < h.details.size(); ++i)
    if (!h.details[i].empty()) std::printf("  scan %zu recovery: %s\n", i, h.details[i].c_str());
}

int main(int argc, char** argv) {
  retainFreedMemory();
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s DATA_DIR [yaw_deg ...]\n", argv[0]);
    return 1;
  }
  std::vector<double> yaws;
  for (int i = 2; i < argc; ++i) yaws.push_back(std::stod(argv[i]));
  if (yaws.empty()) yaws = {10, 20, 30, 45, 60, 90};
  const stress::Sequence kitti = stress::kittiSequence(argv[1], ClassTable::semanticKitti());
  const stress::Sequence ouster = stress::ousterSequence(argv[1]);
  for (double y : yaws) show(stress::suddenYaw(kitti, 3, y * M_PI / 180.0));
  for (double y : yaws) show(stress::suddenYaw(ouster, 1, y * M_PI / 180.0));
  for (int k : {2, 3, 5}) show(stress::dropFrames(kitti, k));
  return 0;
}
