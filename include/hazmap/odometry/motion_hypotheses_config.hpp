#pragma once
// The tracking guess after a sudden turn (issue 35): several motion hypotheses scored cheaply
// against the registration target before the full ICP. An adopted measure, so not a run key
// (DEVELOPERS.md); the fields stay for library callers and for measuring the path before it.

namespace hazmap {

struct MotionHypothesisConfig {
  /// Without wheel odometry: score the constant-velocity guess against the target; when it fits
  /// clearly worse than the guesses of the frames before, also score zero motion, the last
  /// translation without its turn and a yaw sweep, and start ICP from the best. Off: the guess
  /// alone, as before issue 35. With wheel odometry the wheels' guess is used as before.
  bool enabled = true;
  /// rad; the yaw sweep covers ± this around the best of the other hypotheses (0 = no sweep),
  /// at most the plausible turn per frame (recovery.max_rotation): a start beyond it is refused.
  double yaw_range = 3.15;
};

}  // namespace hazmap
