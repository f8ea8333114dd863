#!/usr/bin/env bash
# What the live view costs the pipeline (docs/live.md): `hazmap live` on a simulated naraha
# capture replayed at RATE, the same run three ways, alternating, REPEATS times: without the view
# (--no-view, the peer), with the view and no browser, and with the view and 50 WebSocket clients
# (25 reading everything, 25 that complete the handshake and never read). Prints run.json's
# tracking seconds (preprocessing + registration of every frame, on the pipeline's thread), the
# frames, the datagrams lost (at RATE max the receive thread must keep up with a burst), and
# whether the trajectory equals the peer's byte for byte.
#   scripts/live-view-cost.sh HAZMAP_BIN OUT_DIR [FRAMES=60] [RATE=50] [REPEATS=3]
set -euo pipefail
h=${1:?hazmap binary}; out=${2:?output folder}; frames=${3:-60}; rate=${4:-50}; repeats=${5:-3}
mkdir -p "$out"
capture="$out/naraha-$frames.pcap"
[[ -f "$capture" ]] || "$h" simulate --frames "$frames" --format pcap --out "$capture" > /dev/null
free_port() {
  /usr/bin/python3 -c 'import socket
while True:
    a = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); a.bind(("", 0)); p = a.getsockname()[1]
    b = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try: b.bind(("", p + 1)); print(p); break
    except OSError: pass'
}
# 50 WebSocket clients on PORT until killed: half read and discard, half never read.
clients() {
  /usr/bin/python3 - "$1" > /dev/null 2>&1 <<'PY' &
import socket, sys, threading, time
port = int(sys.argv[1])
hello = (b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
         b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n")
socks = []
for i in range(50):
    s = socket.create_connection(("127.0.0.1", port))
    if i % 2: s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.sendall(hello)
    socks.append(s)
def drain(s):
    while s.recv(1 << 16): pass
for s in socks[::2]: threading.Thread(target=drain, args=(s,), daemon=True).start()
time.sleep(3600)
PY
  cpid=$!
}
for rep in $(seq "$repeats"); do
  for mode in no-view view view+50; do
    dir="$out/$mode-$rep"; rm -rf "$dir"
    port=$(free_port)
    view=(--listen 127.0.0.1:0); [[ $mode == no-view ]] && view=(--no-view)
    "$h" live --sensor velodyne --no-deskew --port "$port" "${view[@]}" --autosave-every 0 --quiet --no-viewer \
      --out "$dir" > "$dir.log" 2>&1 &
    pid=$!
    for _ in $(seq 200); do grep -q "listening on UDP port" "$dir.log" 2>/dev/null && break; sleep 0.05; done
    cpid=""
    if [[ $mode == view+50 ]]; then
      http=$(sed -n 's|^live view: http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$dir.log")
      clients "$http"; sleep 1
    fi
    "$h" replay "$capture" --to 127.0.0.1 --port "$port" --rate "$rate" --quiet
    seen=""
    if [[ $mode == view+50 ]]; then
      seen=$(curl -s "http://127.0.0.1:$http/status" | /usr/bin/python3 -c \
        'import json,sys; j=json.load(sys.stdin); print("clients %d dropped %d" % (j["clients"], j["clients_dropped"]))')
    fi
    kill -INT "$pid"; wait "$pid"
    if [[ -n $cpid ]]; then kill "$cpid"; fi
    same=$(cmp -s "$out/no-view-$rep/trajectory.kitti" "$dir/trajectory.kitti" && echo same || echo DIFFERENT)
    /usr/bin/python3 - "$dir" "$mode" "$same" "$seen" <<'PY'
import json, sys
j = json.load(open(sys.argv[1] + "/run.json"))
print(f"{sys.argv[2]:8s} frames {j['frames']:4d}  tracking {j['timings_s']['tracking']:7.3f} s  "
      f"lost {j['live']['lost']}  trajectory {sys.argv[3]} as no-view  {sys.argv[4]}")
PY
  done
done
