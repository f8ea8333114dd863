#!/usr/bin/env bash
# Latency from a scan's last datagram to its pose, and the tracking rate, of `hazmap live`
# (docs/live.md, issue 33 part 3). One live session per row, alternating the rows REPEATS times:
# a capture replayed on loopback at RATE (for SECONDS with --loop when SECONDS > 0, else once),
# SIGINT, then run.json's live.latency_ms (frames, p50, p99, max), the frames, the frames per
# second of wall time between the first and the last pose (frames / tracking window), and the
# datagrams lost. Each row is `LABEL|ARGS...` (live's own arguments: --method, --set ...).
#   [METADATA=ouster.json] scripts/live-latency.sh HAZMAP_BIN OUT_DIR CAPTURE RATE SECONDS REPEATS 'label|args' ...
#   e.g. scripts/live-latency.sh build/apps/hazmap /tmp/lat velodyne_vlp16.pcap 1 30 2 \
#          'icp|--method icp' 'sync|--method icp+pgo --set slam.back_end=beside-tracking' \
#          'async|--method icp+pgo --set slam.back_end=own-thread'
set -euo pipefail
h=${1:?hazmap binary}; out=${2:?output folder}; capture=${3:?capture}; rate=${4:?rate}
seconds=${5:?seconds}; repeats=${6:?repeats}; shift 6
mkdir -p "$out"
extra=()  # an Ouster capture: its metadata JSON in $METADATA, or beside it with the same name
meta=${METADATA:-${capture%.pcap}.json}
[[ -f "$meta" ]] && extra=(--sensor-metadata "$meta")
sensor=velodyne; [[ ${#extra[@]} -gt 0 ]] && sensor=ouster
free_port() {
  /usr/bin/python3 -c 'import socket
while True:
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); a.bind(("", 0)); p = a.getsockname()[1]
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try: b.bind(("", p + 1)); print(p); break
    except OSError: pass'
}
for rep in $(seq "$repeats"); do
  for row in "$@"; do
    label=${row%%|*}; read -r -a args <<< "${row#*|}"
    dir="$out/$label-$rep"; rm -rf "$dir"
    port=$(free_port)
    "$h" live --sensor "$sensor" "${extra[@]}" --port "$port" --no-view --autosave-every 0 --quiet --no-viewer \
      "${args[@]}" --out "$dir" > "$dir.log" 2>&1 &
    pid=$!
    for _ in $(seq 200); do grep -q "listening on UDP port" "$dir.log" 2>/dev/null && break; sleep 0.05; done
    if [[ $seconds -gt 0 ]]; then
      "$h" replay "$capture" --to 127.0.0.1 --port "$port" --rate "$rate" --loop --quiet & rpid=$!
      sleep "$seconds"; kill -TERM "$rpid"; wait "$rpid" || true
    else
      "$h" replay "$capture" --to 127.0.0.1 --port "$port" --rate "$rate" --quiet
    fi
    sleep 0.5
    kill -INT "$pid"; wait "$pid"
    /usr/bin/python3 - "$dir" "$label" <<'PY'
import json, sys
j = json.load(open(sys.argv[1] + "/run.json")); l = j["live"]["latency_ms"]
print(f"{sys.argv[2]:10s} frames {j['frames']:5d}  latency p50 {l['p50']:7.1f}  p99 {l['p99']:7.1f}  "
      f"max {l['max']:7.1f} ms  tracking {j['timings_s']['tracking']:7.3f} s  loops {j['loop_closure']['accepted']}  "
      f"lost {j['live']['lost']}")
PY
  done
done
