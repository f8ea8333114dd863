#!/usr/bin/env bash
# Checks that every #include "hazmap/<stage>/..." in src/ and include/ points down the documented
# data flow (DEVELOPERS.md, "Layout"):
#
#   core, io  <  sources < properties < preprocess < registration < odometry < loop < graph
#             <  map < eval < pipeline < demo
#
# A stage may include itself and any stage to its left. core and io are below everything (core
# includes only core). sim stands beside the flow: it may use core, io, sources, properties and preprocess, and only
# demo (and apps/, tests/, bench/, which are not checked) may use it. Also rejects includes that
# climb out of a stage's folder ("../"). The few documented exceptions are listed below; the one
# of properties reverses its arrow: preprocess may not include properties. The build enforces the
# same arrows (cmake/stages.cmake: one library per stage, each compiled against the headers of the
# stages it may use only); this script also names the file and line.
#
#   scripts/check-layers.sh        prints each violation as file:line: <stage> -> <stage>, exit 1
set -euo pipefail
cd "$(dirname "$0")/.."

declare -A rank=(
  [core]=0 [io]=1 [sources]=2 [properties]=3 [preprocess]=4 [registration]=5 [odometry]=6
  [loop]=7 [graph]=8 [map]=9 [eval]=10 [pipeline]=11 [demo]=12
)
# sim: beside the flow. What it may use, and who may use it.
sim_uses="core io sources properties preprocess"
sim_users="demo sim"
# Allowed exceptions: "<stage> <included header>", each with its reason in a comment above it.
exceptions=(
  # Normals are shared low-level geometry (PCA over neighbours; with the spatial index it uses,
  # only core below): properties needs them for the normal_z rule variable on the raw scan,
  # preprocess for ICP targets.
  "properties hazmap/preprocess/normals.hpp"
  # The same normals' neighbour search, which normals.hpp's interface takes (normalAt) and the
  # labeller builds itself for the footprints and for normal_z between scan lines.
  "properties hazmap/preprocess/spatial_index.hpp"
)

allowed() {  # allowed <from> <to>
  local from=$1 to=$2
  [ "$from" = "$to" ] && return 0
  if [ "$to" = sim ]; then [[ " $sim_users " == *" $from "* ]]; return; fi
  if [ "$from" = sim ]; then [[ " $sim_uses " == *" $to "* ]]; return; fi
  [ -n "${rank[$from]:-}" ] && [ -n "${rank[$to]:-}" ] || return 1
  [ "$from" = core ] && return 1  # core includes only core
  # properties uses preprocess's normals (the exception below): the arrow cannot point both ways.
  [ "$from" = preprocess ] && [ "$to" = properties ] && return 1
  [ "${rank[$to]}" -le "${rank[$from]}" ]
}

excepted() {  # excepted <from stage> <included header>
  local e
  for e in "${exceptions[@]}"; do [ "$e" = "$1 $2" ] && return 0; done
  return 1
}

violations=0
# Bash's own regex and expansions, no process per include: the loop sees every #include.
stage_include_re='#include[[:space:]]*"hazmap/([a-z_]+)/'
header_re='#include[[:space:]]*"([^"]+)"'
while IFS= read -r hit; do
  file=${hit%%:*}
  rest=${hit#*:}
  line=${rest%%:*}
  text=${rest#*:}
  case "$file" in
    src/*) from=${file#src/}; from=${from%%/*} ;;
    include/hazmap/*) from=${file#include/hazmap/}; from=${from%%/*} ;;
    *) continue ;;
  esac
  if [[ "$text" == *'"../'* ]]; then
    echo "$file:$line: includes across folders with ../ (use \"hazmap/<stage>/...\")"
    violations=$((violations + 1))
    continue
  fi
  [[ "$text" =~ $stage_include_re ]] || continue
  to=${BASH_REMATCH[1]}
  if [ -z "${rank[$from]:-}" ] && [ "$from" != sim ]; then
    echo "$file:$line: stage '$from' is not in the documented order (scripts/check-layers.sh)"
    violations=$((violations + 1))
  elif [ -z "${rank[$to]:-}" ] && [ "$to" != sim ]; then
    echo "$file:$line: includes stage '$to', which is not in the documented order"
    violations=$((violations + 1))
  elif [[ "$text" =~ $header_re ]] && excepted "$from" "${BASH_REMATCH[1]}"; then
    :
  elif ! allowed "$from" "$to"; then
    echo "$file:$line: $from -> $to points up the data flow"
    violations=$((violations + 1))
  fi
done < <(grep -rnE '^[[:space:]]*#[[:space:]]*include[[:space:]]*"' src include --include='*.hpp' --include='*.cpp' --include='*.h')

if [ "$violations" -gt 0 ]; then
  echo "check-layers: $violations include(s) against the documented order" >&2
  exit 1
fi
echo "check-layers: every include follows the documented order"
