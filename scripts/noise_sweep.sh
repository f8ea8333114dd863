#!/usr/bin/env bash
# The odometry-noise sweep of docs/noise_sweep.md in one command (issue 14): the demo's five
# methods, the paper's set-up and frame to map, naraha seed 1 (whole route), at
#   - slip probability 0 / 0.08 (default) / 0.3,
#   - slip size 0.2-0.5 m (default) / 0.5-1.0 m,
#   - frame spacing 0.5 / 1 (default) / 2 m,
#   - and two combinations (slippery; slippery with 2 m frame spacing).
# Usage: scripts/noise_sweep.sh [OUT_DIR] [extra hazmap noise-sweep options, e.g. --seeds 1-3]
# Re-running reuses every finished point; copy OUT/noise_sweep.png to docs/images/ and the table
# from OUT/noise_sweep.md into docs/noise_sweep.md.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
hazmap="${HAZMAP:-$here/build/apps/hazmap}"
out="${1:-hazmap-noise-sweep}"
shift || true
exec nice "$hazmap" noise-sweep --out "$out" --scenario naraha --seeds 1 \
  --axis odometry.slip_probability=0,0.08,0.3 \
  --axis odometry.slip_min:odometry.slip_max=0.2:0.5,0.5:1.0 \
  --axis robot.frame_distance=0.5,1,2 \
  --point 'slippery@odometry.slip_probability=0.3;odometry.slip_min=0.5;odometry.slip_max=1.0' \
  --point 'slippery+sparse@odometry.slip_probability=0.3;odometry.slip_min=0.5;odometry.slip_max=1.0;robot.frame_distance=2' \
  "$@"
