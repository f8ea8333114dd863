#!/usr/bin/env bash
# The IMU on the crawler's worst day (issue 36): the corridor (and naraha) worst-day sequence with
# the simulated 200 Hz IMU, tracked by `hazmap odometry` (recovery on, suspect frames re-examined,
# as the issue-19 table in docs/registration.md) with the IMU (imu.txt present) and without it
# (the same sequence, imu.txt removed: the peer, same scans byte for byte), with and without wheel
# odometry. Prints per run: frames within 5 cm / 0.5° of their true increment, silently wrong
# (off by > 20 cm / 2° yet tracked or relocalised) of all that far off, and the mean position
# error over the route (no alignment).
# Usage: scripts/imu_worst_day.sh HAZMAP_BIN OUT_DIR [SCENARIO] [SEED] [FRAMES]
set -euo pipefail
h=${1:?hazmap binary}; out=${2:?output folder}; scenario=${3:-corridor}; seed=${4:-1}; frames=${5:-100}
mkdir -p "$out"
seq="$out/$scenario-wd-seed$seed"
[ -d "$seq" ] || "$h" simulate --scenario "$scenario" --worst-day --seed "$seed" --frames "$frames" --imu-rate 200 \
  --out "$seq" > /dev/null
peer="$seq-no-imu"
[ -d "$peer" ] || { cp -r "$seq" "$peer"; rm "$peer/imu.txt"; }
score() {  # poses.txt of a run against the sequence's poses.txt, frames.csv's statuses
  /usr/bin/python3 - "$1" "$2" << 'PY'
import csv, sys
import numpy as np
def poses(path):
    out = []
    for line in open(path):
        v = [float(x) for x in line.split()]
        if len(v) == 12:
            T = np.eye(4); T[:3, :] = np.array(v).reshape(3, 4); out.append(T)
    return out
est, gt = poses(sys.argv[1] + "/poses.txt"), poses(sys.argv[2] + "/poses.txt")
status = [r["status"] for r in csv.DictReader(open(sys.argv[1] + "/frames.csv"))]
within = far = silent = 0
for i in range(1, len(est)):
    E = np.linalg.inv(np.linalg.inv(gt[i - 1]) @ gt[i]) @ (np.linalg.inv(est[i - 1]) @ est[i])
    t = np.linalg.norm(E[:3, 3]); r = np.degrees(np.arccos(np.clip((np.trace(E[:3, :3]) - 1) / 2, -1, 1)))
    within += t <= 0.05 and r <= 0.5
    if t > 0.2 or r > 2:
        far += 1; silent += status[i] in ("tracked", "relocalised")
mean_err = np.mean([np.linalg.norm(a[:3, 3] - b[:3, 3]) for a, b in zip(est, gt)])
print(f"within {within}/{len(est) - 1} ({100.0 * within / (len(est) - 1):.1f} %), silently wrong {silent} of {far}, "
      f"mean position error {mean_err:.3f} m")
PY
}
for wheel in wheel no-wheel; do
  for imu in imu no-imu; do
    s=$seq; [ $imu = no-imu ] && s=$peer
    flags=(--set recovery.relocalise=true --set recovery.relocalise_suspect=true)
    [ $wheel = no-wheel ] && flags+=(--no-wheel)
    run="$out/$scenario-seed$seed-$wheel-$imu"
    "$h" odometry "$s" --out "$run" --quiet "${flags[@]}" > "$run.log" 2>&1 || { echo "$run: failed"; tail -3 "$run.log"; continue; }
    echo "$scenario seed $seed, $wheel, $imu: $(score "$run" "$s")"
  done
done
