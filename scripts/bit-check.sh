#!/usr/bin/env bash
# Bit-for-bit check of the default paths (DEVELOPERS.md: a change meant to keep results is checked
# so). Runs every default path with one binary into a folder; compare two such folders with
# --compare. About 10 minutes of both cores per run.
#   scripts/bit-check.sh run HAZMAP_BIN OUT_DIR [SHARED_DATA_DIR]
#   scripts/bit-check.sh compare BASE_DIR NEW_DIR      (exit 1 when any file differs)
# Runs: hazmap demo seeds 1 and 2 (naraha, both set-ups, camera labels), corridor 1 and tanks 1,
# the worst day (seed 3: icp, property-icp, property-icp+pgo), tanks 3 (property-icp, icp+pgo),
# the real VLP-16 bag and Ouster OS-1-128 capture (icp+pgo), odometry on the real KITTI sample.
set -uo pipefail
mode=${1:?usage: bit-check.sh run BIN OUT [DATA] | compare BASE NEW}
if [[ $mode == compare ]]; then
  a=${2:?base folder}; b=${3:?new folder}; n=0; bad=0
  while IFS= read -r f; do
    n=$((n + 1))
    cmp -s "$a/$f" "$b/$f" || { echo "differs: $f"; bad=$((bad + 1)); }
  done < <(cd "$a" && find . \( -name '*.kitti' -o -name graph.g2o \) | sort)
  echo "$n files compared, $bad differ"
  [[ $bad -eq 0 ]]; exit
fi
h=${2:?hazmap binary}; out=${3:?output folder}
data=${4:-$(cd "$(dirname "$0")/../.." && pwd)/shared/data}
[[ -x $h ]] || { echo "bit-check: $h is not an executable"; exit 1; }
[[ -d $data ]] || { echo "bit-check: shared data not found: $data"; exit 1; }
mkdir -p "$out"
t0=$(date +%s)
"$h" demo --seed 1 --out "$out/naraha1" --threads 2 > "$out/naraha1.log" 2>&1 &
"$h" demo --seed 2 --out "$out/naraha2" --threads 2 > "$out/naraha2.log" 2>&1
wait
"$h" demo --scenario corridor --seed 1 --out "$out/corridor1" --no-camera-labels --threads 2 > "$out/corridor1.log" 2>&1 &
"$h" demo --scenario tanks --seed 1 --out "$out/tanks1" --no-camera-labels --threads 2 > "$out/tanks1.log" 2>&1
wait
"$h" simulate --worst-day --seed 3 --out "$out/wd-seq" > /dev/null 2>&1
for m in icp property-icp property-icp+pgo; do
  "$h" run "$out/wd-seq" --method "$m" --out "$out/wd-$m" --quiet --no-viewer > "$out/wd-$m.log" 2>&1
done
"$h" simulate --scenario tanks --seed 3 --out "$out/tanks3-seq" > /dev/null 2>&1
for m in property-icp icp+pgo; do
  "$h" run "$out/tanks3-seq" --method "$m" --out "$out/tanks3-$m" --quiet --no-viewer > "$out/tanks3-$m.log" 2>&1
done
"$h" run "$data/sensors/velodyne-vlp16" --method icp+pgo --out "$out/vlp16" --quiet --no-viewer > "$out/vlp16.log" 2>&1
"$h" run "$data"/sensors/ouster-os1-128/*.pcap --method icp+pgo --out "$out/os1" --quiet --no-viewer > "$out/os1.log" 2>&1
"$h" odometry "$data/kitti-semantic-sample" --out "$out/kitti-odo" > "$out/kitti-odo.log" 2>&1
echo "bit-check: $(( $(date +%s) - t0 )) s -> $out"
