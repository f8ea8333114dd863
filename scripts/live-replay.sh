#!/usr/bin/env bash
# Measures hazmap live against hazmap run on one capture (docs/live.md): `hazmap run` on the
# capture, then `hazmap live` fed by `hazmap replay` over loopback at RATE, stopped by SIGINT;
# prints both frame counts, the largest pose difference and the live run's loss counts.
#   scripts/live-replay.sh HAZMAP_BIN CAPTURE RATE OUT_DIR [live args, e.g. --sensor ouster --sensor-metadata M]
set -euo pipefail
h=${1:?hazmap binary}; capture=${2:?capture}; rate=${3:?rate}; out=${4:?output folder}; shift 4
live_args=("$@"); [[ ${#live_args[@]} -gt 0 ]] || live_args=(--sensor velodyne)
mkdir -p "$out"; rm -rf "$out/run" "$out/live"
"$h" run "$capture" --quiet --no-viewer --out "$out/run" ${HAZMAP_RUN_ARGS:-}
port=$(/usr/bin/python3 -c 'import socket
while True:
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); a.bind(("", 0)); p = a.getsockname()[1]
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try: b.bind(("", p + 1)); print(p); break
    except OSError: pass')
"$h" live "${live_args[@]}" --port "$port" --listen 127.0.0.1:0 --quiet --no-viewer --out "$out/live" > "$out/live.log" 2>&1 &
pid=$!
for _ in $(seq 200); do grep -q "listening on UDP port" "$out/live.log" && break; sleep 0.05; done
"$h" replay "$capture" --to 127.0.0.1 --port "$port" --rate "$rate" --quiet
kill -INT "$pid"; wait "$pid"
/usr/bin/python3 - "$out" <<'PY'
import json, math, sys
out = sys.argv[1]
def poses(path):
    return [[float(v) for v in line.split()] for line in open(path) if line.strip()]
a, b = poses(out + "/run/trajectory.kitti"), poses(out + "/live/trajectory.kitti")
dt = dr = 0.0
for p, q in zip(a, b):
    dt = max(dt, math.dist([p[3], p[7], p[11]], [q[3], q[7], q[11]]))
    R = [[p[0], p[1], p[2]], [p[4], p[5], p[6]], [p[8], p[9], p[10]]]
    S = [[q[0], q[1], q[2]], [q[4], q[5], q[6]], [q[8], q[9], q[10]]]
    tr = sum(R[k][i] * S[k][i] for i in range(3) for k in range(3))  # trace(Rᵀ S)
    dr = max(dr, math.degrees(math.acos(max(-1.0, min(1.0, (tr - 1) / 2)))))
live = json.load(open(out + "/live/run.json"))["live"]
print(f"frames run {len(a)} live {len(b)}; max pose difference {dt * 1e3:.4f} mm {dr:.5f} deg; "
      f"received {live['received']} lost {live['lost']} (kernel {live['kernel_dropped']}, queue {live['queue_dropped']}) "
      f"scans skipped {live['scans_skipped']}")
PY
