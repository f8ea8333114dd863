#!/usr/bin/env bash
# Installs the build tree into a temporary prefix and builds a tiny consumer project with
# find_package(hazmap) against it. Args: SOURCE_DIR BINARY_DIR HAZMAP_CLI
set -euo pipefail
src=$1; bin=$2
tmp=$(mktemp -d "$bin/io_consumer.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
cmake --install "$bin" --prefix "$tmp/prefix" > "$tmp/install.log" 2>&1 || { cat "$tmp/install.log"; exit 1; }
[[ -f "$tmp/prefix/include/hazmap/io/pcd.hpp" ]] || { echo "FAIL: headers not installed"; exit 1; }
[[ -x "$tmp/prefix/bin/hazmap" ]] || { echo "FAIL: CLI not installed"; exit 1; }
mkdir -p "$tmp/consumer"
cat > "$tmp/consumer/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.20)
project(hazmap_consumer CXX)
set(CMAKE_CXX_STANDARD 20)
find_package(hazmap 0.1 REQUIRED)
add_executable(consumer main.cpp)
target_link_libraries(consumer PRIVATE hazmap::hazmap)
# One stage alone (cmake/stages.cmake): io brings core, and nothing above it.
add_executable(consumer_io main.cpp)
target_link_libraries(consumer_io PRIVATE hazmap::io)
CMAKE
cat > "$tmp/consumer/main.cpp" <<'CPP'
#include <hazmap/io/cloud_file.hpp>
#include <hazmap/io/read_stats.hpp>
#include <iostream>
int main(int argc, char** argv) {
  if (argc != 2) return 2;
  hazmap::ReadStats st;
  const auto cloud = hazmap::readCloud(argv[1], hazmap::ClassTable::semanticKitti(), &st);
  std::size_t heat = 0;
  for (auto c : cloud.classes) heat += c == 1;
  std::cout << cloud.size() << " " << heat << "\n";
}
CPP
flags=()
[[ -n "${CMAKE_BUILD_TYPE:-}" ]] && flags+=("-DCMAKE_BUILD_TYPE=$CMAKE_BUILD_TYPE")
# Same sanitizer flags as the library (an ASan build of hazmap needs an ASan consumer).
if grep -q "HAZMAP_SANITIZE:BOOL=ON" "$bin/CMakeCache.txt"; then
  flags+=("-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
fi
cmake -S "$tmp/consumer" -B "$tmp/build" -DCMAKE_PREFIX_PATH="$tmp/prefix" "${flags[@]}" > "$tmp/configure.log" 2>&1 \
  || { cat "$tmp/configure.log"; echo "FAIL: find_package(hazmap) against the installed tree"; exit 1; }
cmake --build "$tmp/build" > "$tmp/build.log" 2>&1 || { cat "$tmp/build.log"; echo "FAIL: consumer build"; exit 1; }
# The shared data as configured (HAZMAP_SHARED_DATA_DIR), else beside the source tree.
data=$(sed -n 's/^HAZMAP_SHARED_DATA_DIR:[A-Z]*=//p' "$bin/CMakeCache.txt")
[[ -n "$data" ]] || data="$src/../shared/data"
scan="$data/kitti-semantic-sample/velodyne/000000.bin"
[[ -f "$scan" ]] || { echo "FAIL: shared test data not found: $scan (configure with -DHAZMAP_SHARED_DATA_DIR=<dir>)"; exit 1; }
out=$("$tmp/build/consumer" "$scan")
[[ "$out" == "124668 532" ]] || { echo "FAIL: consumer printed '$out', expected '124668 532'"; exit 1; }
out_io=$("$tmp/build/consumer_io" "$scan")
[[ "$out_io" == "$out" ]] || { echo "FAIL: consumer linked to hazmap::io printed '$out_io'"; exit 1; }
echo "OK: installed tree works with find_package(hazmap): $out"
