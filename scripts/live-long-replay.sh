#!/usr/bin/env bash
# A long `hazmap live` session (docs/live.md, issue 33: memory and latency over a long mission):
# CAPTURE replayed on loopback with --loop at RATE for SECONDS, the live view on (no browser) and
# the default autosave; every STEP seconds one line of: elapsed s, resident memory (VmRSS, MiB),
# frames, /status latency_ms p50 / p99 / max (the last 600 frames), the back end's backlog,
# map points, map corrections, datagrams received and lost, the spool's size (MiB), the age of the
# newest complete save's state and how long writing it took (s; None before one). Then SIGINT and
# run.json's frames, loops and live.latency_ms (the whole run).
#   scripts/live-long-replay.sh HAZMAP_BIN OUT_DIR CAPTURE RATE SECONDS STEP [live args...]
#   e.g. nice -n 10 scripts/live-long-replay.sh build/hazmap /tmp/long naraha.pcap 100 1800 30 --no-deskew
set -euo pipefail
h=${1:?hazmap binary}; out=${2:?output folder}; capture=${3:?capture}; rate=${4:?rate}
seconds=${5:?seconds}; step=${6:?step}; shift 6
rm -rf "$out"; mkdir -p "$out"
port=$(/usr/bin/python3 -c 'import socket
while True:
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); a.bind(("", 0)); p = a.getsockname()[1]
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try: b.bind(("", p + 1)); print(p); break
    except OSError: pass')
"$h" live --sensor velodyne --port "$port" --listen 127.0.0.1:0 --no-viewer "$@" --out "$out/run" > "$out/live.log" 2>&1 &
pid=$!
for _ in $(seq 400); do grep -q "listening on UDP port" "$out/live.log" 2>/dev/null && break; sleep 0.05; done
# HAZMAP_BIN may be a wrapper (heaptrack's script, nice, taskset): the live process itself is the
# newest one with this run's --out, and it is the one measured and sent SIGINT.
live=$(pgrep -n -f -- "--out $out/run" || echo "$pid")
view=$(sed -n 's|^live view: http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$out/live.log")
"$h" replay "$capture" --to 127.0.0.1 --port "$port" --rate "$rate" --loop --quiet & rpid=$!
sleep 0.2
replay=$(pgrep -n -f -- "replay .*--port $port " || echo "$rpid")
start=$(date +%s)
printf "elapsed_s\trss_mib\tframes\tp50_ms\tp99_ms\tmax_ms\tbacklog\tmap_points\tcorrections\treceived\tdrops\tspool_mib\tsave_age_s\tsave_s\n" \
  | tee "$out/samples.tsv"
while (( $(date +%s) - start < seconds )); do
  sleep "$step"
  rss=$(awk '/VmRSS/ {printf "%.0f", $2 / 1024}' "/proc/$live/status")
  spool=$(du -m "$out/run/live.pcap" | cut -f1)
  curl -s "http://127.0.0.1:$view/status" | /usr/bin/python3 -c '
import json, sys
s = json.load(sys.stdin); l = s.get("latency_ms") or {}
print("\t".join(str(x) for x in [sys.argv[1], sys.argv[2], s["frames"], l.get("p50"), l.get("p99"), l.get("max"),
      s.get("back_end_backlog"), s["map_points"], s.get("map_corrections"), s["packets"], s["drops"], sys.argv[3],
      s.get("last_save_age_s"), s.get("last_save_seconds")]))
' "$(( $(date +%s) - start ))" "$rss" "$spool" | tee -a "$out/samples.tsv"
done
kill -TERM "$replay" "$rpid" 2>/dev/null; wait "$rpid" || true
sleep 1
kill -INT "$live"; wait "$pid"
/usr/bin/python3 - "$out/run" <<'PY'
import json, sys
j = json.load(open(sys.argv[1] + "/run.json")); l = j["live"]["latency_ms"]
print(f"run.json: frames {j['frames']}  loops {j['loop_closure']['accepted']}  latency p50 {l['p50']:.1f}  "
      f"p99 {l['p99']:.1f}  max {l['max']:.1f} ms  lost {j['live']['lost']}  scans skipped {j['live']['scans_skipped']}")
PY
