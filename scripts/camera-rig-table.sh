#!/usr/bin/env bash
# Camera rig on simulated naraha: property ICP + PGO on labels from a 360° rig (four 90°
# thermal and four 90° NIR cameras, `simulate --camera-rig ring4`) against the simulator's
# ground-truth labels, in both set-ups (frame to local map, the default; the paper's frame to
# frame). Prints one markdown row per seed: map error [m] ground truth / camera (change); ✗ =
# more than 20 % above ground truth (issue 36's target). Ground truth twice: the simulator's
# labels/ (with its random label noise, labels.false_property and property_dropout) and the
# noise-free labels_true/ (a folder beside the run whose labels/ is a link to it).
# docs/properties.md "Camera rigs".
#
#   scripts/camera-rig-table.sh BIN WORKDIR SEED...      e.g. build/apps/hazmap /tmp/rig 1 2
set -euo pipefail
bin=$(realpath "$1"); work=$2; shift 2
[[ $# -gt 0 ]] || { echo "usage: $0 BIN WORKDIR SEED..." >&2; exit 2; }
mkdir -p "$work"
threads=${THREADS:-1}
err() { /usr/bin/python3 -c 'import json,sys; print("%.4f" % json.load(open(sys.argv[1]))["map_error"]["point"]["mean"])' "$1/run.json"; }
cell() { /usr/bin/python3 -c 'import sys; g,c=map(float,sys.argv[1:]); d=100*(c-g)/g; print("%.4f / %.4f (%+.0f %%%s)" % (g,c,d," ✗" if d>20 else ""))' "$1" "$2"; }
echo "| seed | frame to map: labels/ / camera | frame to map: labels_true/ / camera | paper's set-up: labels/ / camera | paper's set-up: labels_true/ / camera |"
echo "|---|---|---|---|---|"
for seed in "$@"; do
  s="$work/naraha-$seed"
  [[ -f "$s/times.txt" ]] || "$bin" simulate --scenario naraha --seed "$seed" --cameras thermal,nir --camera-rig ring4 \
      --out "$s" --overwrite > "$s.simulate.log"
  [[ -f "$s-labelled/times.txt" ]] || "$bin" label "$s" --camera "$s/cameras/rig.yaml" --out "$s-labelled" --overwrite \
      > "$s.label.log"
  mkdir -p "$s-noise-free"
  for e in "$s"/*; do
    n=$(basename "$e"); [[ $n == labels || $n == labels_true ]] || ln -sfn "$e" "$s-noise-free/$n"
  done
  ln -sfn "$s/labels_true" "$s-noise-free/labels"
  row="| $seed"
  for setup in map frame; do
    for labels in truth noise-free camera; do
      in=$s; [[ $labels == camera ]] && in=$s-labelled; [[ $labels == noise-free ]] && in=$s-noise-free
      out="$work/run-$seed-$setup-$labels"
      [[ -f "$out/run.json" ]] || "$bin" run "$in" --method property-icp+pgo --threads "$threads" --quiet --no-viewer \
          --set odometry.mode=$setup --out "$out"
    done
    for labels in truth noise-free; do
      row+=" | $(cell "$(err "$work/run-$seed-$setup-$labels")" "$(err "$work/run-$seed-$setup-camera")")"
    done
  done
  echo "$row |"
done
