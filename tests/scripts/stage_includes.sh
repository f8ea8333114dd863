#!/usr/bin/env bash
# The per-stage libraries (cmake/stages.cmake) enforce the layering at compile time: a stage's
# files see only the headers of the stages it may use. For a few arrows each way, preprocesses a
# probe including one header with the exact flags the build uses for a file of the stage
# (compile_commands.json) and checks that every header is found when the arrow is allowed and that
# it fails with "No such file" when it points up the flow. Args: SOURCE_DIR BINARY_DIR [HAZMAP_CLI].
set -euo pipefail
src=${1:?usage: stage_includes.sh SOURCE_DIR BINARY_DIR}
bin=${2:?usage: stage_includes.sh SOURCE_DIR BINARY_DIR}
[[ -f "$bin/compile_commands.json" ]] || { echo "FAIL: no $bin/compile_commands.json"; exit 1; }
tmp=$(mktemp -d "$bin/stage_includes.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

# stage, header, expected (ok | refused)
cases=(
  "core hazmap/core/labeled_cloud.hpp ok"
  "core hazmap/io/pcd.hpp refused"
  "io hazmap/graph/pose_graph.hpp refused"
  "preprocess hazmap/core/labeled_cloud.hpp ok"
  "preprocess hazmap/registration/registration.hpp refused"
  "preprocess hazmap/properties/labeler.hpp refused"
  "properties hazmap/preprocess/normals.hpp ok"
  "properties hazmap/preprocess/voxel_downsample.hpp refused"
  "registration hazmap/preprocess/voxel_downsample.hpp ok"
  "registration hazmap/odometry/odometry.hpp refused"
  "eval map/voxel_hash.hpp ok"
  "map hazmap/eval/trajectory_metrics.hpp refused"
  "pipeline hazmap/eval/trajectory_metrics.hpp ok"
  "pipeline hazmap/demo/demo.hpp refused"
  "pipeline hazmap/sim/simulator.hpp refused"
  "sim hazmap/pipeline/slam.hpp refused"
  "demo hazmap/sim/simulator.hpp ok"
  "odometry map/voxel_hash.hpp refused"
)
failures=0
for c in "${cases[@]}"; do
  read -r stage header expected <<< "$c"
  probe="$tmp/probe_${stage}_$(echo "$header" | tr '/.' '__').cpp"
  printf '#include "%s"\nint main() { return 0; }\n' "$header" > "$probe"
  # The build's command for the stage's first file, preprocessing the probe instead: an arrow is
  # an include path, so finding every header (or "No such file") is the whole question, and the
  # preprocessor answers it without parsing Eigen's templates.
  cmd=$(python3 - "$bin/compile_commands.json" "$src/src/$stage/" "$probe" <<'PY'
import json, shlex, sys
entries = json.load(open(sys.argv[1]))
entry = next((e for e in entries if e["file"].startswith(sys.argv[2])), None)
if entry is None:
    sys.exit("no compile command for a file of " + sys.argv[2])
args = shlex.split(entry["command"]) if "command" in entry else entry["arguments"]
if args[0].endswith("ccache"):
    args = args[1:]
out, skip = [], False
for a in args:
    if skip:
        skip = False
        continue
    if a in ("-o", "-c", "-MF", "-MT", "-MD", "-MQ"):
        skip = a in ("-o", "-c", "-MF", "-MT", "-MQ")
        continue
    if a == entry["file"]:
        continue
    out.append(a)
print("cd " + shlex.quote(entry["directory"]) + " && " + shlex.join(out + ["-E", "-o", "/dev/null", sys.argv[3]]))
PY
)
  if log=$(bash -c "$cmd" 2>&1); then got=ok; else got=refused; fi
  if [[ "$got" != "$expected" ]]; then
    echo "FAIL: $stage including $header: expected $expected, got $got"
    echo "$log" | head -5
    failures=$((failures + 1))
  elif [[ "$got" == refused && "$log" != *"No such file"* ]]; then
    echo "FAIL: $stage including $header failed for another reason:"
    echo "$log" | head -5
    failures=$((failures + 1))
  fi
done
[[ $failures -eq 0 ]] || exit 1
echo "stage includes: ${#cases[@]} arrows as documented"
