#!/usr/bin/env bash
# What the worst-day corridor's data can tell along the corridor, per frame (docs/registration.md,
# "Observability, measured"): builds the measurement tool and writes one CSV per seed.
# Usage: scripts/corridor_observability.sh [BUILD_DIR] [OUT_DIR] [SEED...]   (defaults: build, ., 1 2)
# Env: FRAMES (default 100), TARGETS=1 also writes the corridor's issue-19 targets row per seed.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
out=${2:-.}
shift $(( $# < 2 ? $# : 2 ))
seeds=("${@:-1 2}")
[ -f "$build/CMakeCache.txt" ] || { echo "corridor_observability.sh: $build is not a configured build folder" >&2; exit 1; }
cmake --build "$build" --target corridor_observability >/dev/null
mkdir -p "$out"
for seed in ${seeds[*]}; do
  "$build/scripts/corridor_observability" --seed "$seed" --frames "${FRAMES:-100}" --out "$out/corridor-observability-seed$seed.csv"
  if [ "${TARGETS:-0}" = 1 ]; then
    "$build/scripts/corridor_observability" --targets --seed "$seed" --frames "${FRAMES:-100}" \
      --out "$out/corridor-targets-seed$seed.csv"
  fi
done
