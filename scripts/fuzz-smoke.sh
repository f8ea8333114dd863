#!/usr/bin/env bash
# `make fuzz`: builds the libFuzzer targets (fuzz/) with clang, ASan and UBSan in a separate build
# folder and runs each for a few seconds on a seed corpus made from the real shared data.
# Skips (passes with a message) when clang or its fuzzer runtime is missing
# (`scripts/install-deps.sh --fuzz` installs them). `make test` runs the same targets without
# clang: fuzz/replay (seeds and deterministic mutants, in the normal build).
# Args: SOURCE_DIR BINARY_DIR. Env: HAZMAP_FUZZ_SECONDS (per target, default 5),
# HAZMAP_SHARED_DATA_DIR (default SOURCE_DIR/../shared/data).
set -euo pipefail
src=$1; bin=$2
data=${HAZMAP_SHARED_DATA_DIR:-$src/../shared/data}
[[ -d "$data" ]] || { echo "FAIL: shared test data not found: $data (configure with -DHAZMAP_SHARED_DATA_DIR=<dir>)"; exit 1; }
seconds=${HAZMAP_FUZZ_SECONDS:-5}
cc=$(command -v clang || command -v clang-14 || true)
cxx=$(command -v clang++ || command -v clang++-14 || true)
if [[ -z "$cc" || -z "$cxx" ]]; then
  echo "SKIP: clang not found (install clang and libclang-rt-14-dev to fuzz)"; exit 0
fi
if ! echo 'extern "C" int LLVMFuzzerTestOneInput(const char*, unsigned long) { return 0; }' |
     "$cxx" -x c++ -fsanitize=fuzzer -o /dev/null - 2> /dev/null; then
  echo "SKIP: clang has no libFuzzer runtime (install libclang-rt-14-dev)"; exit 0
fi
if grep -q "^HAZMAP_SANITIZE:BOOL=ON" "$bin/CMakeCache.txt" 2> /dev/null; then
  echo "SKIP: the fuzz smoke run belongs to the normal build (the fuzzers already use ASan + UBSan)"; exit 0
fi
fuzz_build="$bin/io-fuzz"
log="$fuzz_build/smoke.log"
mkdir -p "$fuzz_build"
# Ninja starts the next library's files while one is linking; ccache (where a developer has it)
# makes a re-run of the suite skip the clang build. A folder keeps the generator it was made with.
extra=()
[[ ! -f "$fuzz_build/CMakeCache.txt" ]] && command -v ninja > /dev/null && extra+=(-G Ninja)
command -v ccache > /dev/null && extra+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
CC="$cc" CXX="$cxx" cmake -S "$src" -B "$fuzz_build" "${extra[@]}" -DHAZMAP_FUZZ=ON -DHAZMAP_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" \
  -DHAZMAP_SANITIZE=OFF > "$log" 2>&1 || { cat "$log"; exit 1; }
targets=(fuzz_pcd fuzz_ply fuzz_kitti fuzz_trajectory fuzz_class_table fuzz_velodyne fuzz_hesai fuzz_pcap fuzz_ouster fuzz_imu
         fuzz_mcap fuzz_ros1_bag fuzz_rosbag2 fuzz_ros_messages fuzz_hazards_json fuzz_config fuzz_mission_json)
cmake --build "$fuzz_build" -j 2 --target "${targets[@]}" hazmap_fuzz_seeds hazmap_fuzz_sensor_seeds \
  hazmap_fuzz_bag_seeds >> "$log" 2>&1 || { tail -50 "$log"; exit 1; }
seeds="$fuzz_build/seeds"
rm -rf "$seeds"
"$fuzz_build/fuzz/hazmap_fuzz_seeds" "$data" "$src" "$seeds"
"$fuzz_build/fuzz/hazmap_fuzz_sensor_seeds" "$data" "$seeds"
"$fuzz_build/fuzz/hazmap_fuzz_bag_seeds" "$data" "$seeds"
export HAZMAP_FUZZ_DB3="$seeds/run_0.db3"  # the .db3 fuzz_rosbag2's metadata.yaml points at
# Two targets at a time (the machines have two cores); each writes its own log, read after.
fuzz_one() {
  local t=$1 name=${1#fuzz_}
  local corpus="$fuzz_build/corpus/$name"   # grows across runs; the seeds are re-read every time
  mkdir -p "$corpus" "$seeds/$name"
  (cd "$fuzz_build" && "$fuzz_build/fuzz/$t" -max_total_time="$seconds" -rss_limit_mb=2048 \
     -malloc_limit_mb=1024 -timeout=10 -max_len=65536 -print_final_stats=1 \
     -artifact_prefix="$fuzz_build/crash-$name-" "$corpus" "$seeds/$name" > "$fuzz_build/$name.log" 2>&1)
  echo $? > "$fuzz_build/$name.status"
}
for ((i = 0; i < ${#targets[@]}; i += 2)); do
  fuzz_one "${targets[i]}" &
  [[ -n "${targets[i + 1]:-}" ]] && fuzz_one "${targets[i + 1]}" &
  wait
done
status=0
for t in "${targets[@]}"; do
  name=${t#fuzz_}
  if [[ "$(cat "$fuzz_build/$name.status")" != 0 ]]; then
    echo "FAIL: $t found a problem (log: $fuzz_build/$name.log)"
    grep -E "ERROR|SUMMARY|==[0-9]+==|Test unit written" "$fuzz_build/$name.log" | head -20
    status=1
  else
    echo "OK: $t $(grep -E '^stat::number_of_executed_units' "$fuzz_build/$name.log" | awk '{print $2}') runs in ${seconds}s, $(grep -oE 'cov: [0-9]+' "$fuzz_build/$name.log" | tail -1)"
  fi
done
exit $status
