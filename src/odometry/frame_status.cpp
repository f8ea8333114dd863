// The names of a frame's status and of the tracking mode, for logs, run.json and the CLI.
#include "hazmap/odometry/odometry.hpp"

namespace hazmap {

const char* toString(OdometryMode mode) { return mode == OdometryMode::FrameToFrame ? "frame" : "map"; }

const char* toString(FrameStatus status) {
  switch (status) {
    case FrameStatus::First: return "first";
    case FrameStatus::Tracked: return "tracked";
    case FrameStatus::Degenerate: return "degenerate";
    case FrameStatus::Relocalised: return "relocalised";
    case FrameStatus::Fallback: return "fallback";
  }
  return "unknown";
}

const char* describe(FrameStatus status) {
  switch (status) {
    case FrameStatus::First: return "first: the initial pose";
    case FrameStatus::Tracked: return "tracked: ICP from the guess";
    case FrameStatus::Degenerate: return "tracked: ICP from the guess, the guess kept along degenerate directions";
    case FrameStatus::Relocalised: return "relocalised: global registration (no guess) verified by ICP";
    case FrameStatus::Fallback: return "fallback: nothing verified, the guessed increment used (flagged)";
  }
  return "unknown";
}

}  // namespace hazmap
