#!/usr/bin/env bash
# The alignment guard (cmake/alignment_guard.hpp, issue 37 part 4) is force-included into every
# C++ translation unit of the build, so a std::stable_sort / stable_partition / inplace_merge
# over an over-aligned element type does not compile. This test proves the two things the build
# cannot prove about itself:
#   1. the guard still fires (libstdc++'s internals could change under it): a stable sort over a
#      struct holding an Eigen::Isometry3d is refused, one over a Vector3d accepted, both in the
#      default (SSE) and in an AVX-512 compile (-march=x86-64-v4; nothing runs, any x86-64 will do);
#   2. every C++ translation unit in compile_commands.json reads it (its own --include, or a
#      precompiled header whose source includes it).
#   scripts/check-alignment.sh <build dir>     exit 0 when both hold; else what failed, exit 1
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:?usage: scripts/check-alignment.sh <build dir>}" && pwd)"
guard="$root/cmake/alignment_guard.hpp"
db="$build/compile_commands.json"
[[ -f "$db" ]] || { echo "check-alignment: $db: missing (configure with CMAKE_EXPORT_COMPILE_COMMANDS)"; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

cat > "$work/self_test.cpp" <<'CPP'
#include <algorithm>
#include <vector>
#include <Eigen/Geometry>
struct Unaligned { Eigen::Vector3d p; double key; };
struct OverAligned { Eigen::Isometry3d T; double key; };
void fine(std::vector<Unaligned>& v) {
  std::stable_sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
}
#ifdef HAZMAP_SELF_TEST_BAD
void bad(std::vector<OverAligned>& v) {
  std::stable_sort(v.begin(), v.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
}
#endif
CPP
cxx="${CXX:-c++}"
for arch in "" "-march=x86-64-v4"; do
  flags=(-std=c++20 -fsyntax-only -I/usr/include/eigen3 --include="$guard" $arch)
  if ! "$cxx" "${flags[@]}" "$work/self_test.cpp" 2> "$work/self.log"; then
    echo "check-alignment: self-test ${arch:-default}: the guard refuses a type it must accept:"
    cat "$work/self.log"; exit 1
  fi
  if "$cxx" "${flags[@]}" -DHAZMAP_SELF_TEST_BAD "$work/self_test.cpp" 2> "$work/self.log" \
       || ! grep -q "hazmap alignment check" "$work/self.log"; then
    echo "check-alignment: self-test ${arch:-default}: the guard no longer catches a stable_sort over an"
    echo "  Eigen::Isometry3d (libstdc++'s std::_Temporary_buffer changed?): fix $guard"; exit 1
  fi
done

python3 - "$db" "$guard" <<'PY'
import json, os, re, shlex, sys
db, guard = sys.argv[1:3]
pch_reads_guard = {}
def reads_guard(args, directory):
    for i, a in enumerate(args):
        if a in (f"--include={guard}", f"-include{guard}") or (a == "-include" and args[i + 1] == guard):
            return True
    for i, a in enumerate(args):  # CMake's PCH: -include <dir>/cmake_pch.hxx (a .gch beside it)
        path = a[len("-include"):] if a.startswith("-include") and a != "-include" else \
            (args[i + 1] if a == "-include" else None)
        if path and path.endswith("cmake_pch.hxx"):
            path = os.path.join(directory, path)
            if path not in pch_reads_guard:
                pch_reads_guard[path] = os.path.isfile(path) and guard in open(path).read()
            if pch_reads_guard[path]:
                return True
    return False
units, missing = 0, []
for e in json.load(open(db)):
    if not re.search(r"\.(cpp|cc|cxx)$", e["file"]):
        continue
    args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
    units += 1
    if not reads_guard(args, e["directory"]):
        missing.append(e["file"])
if missing:
    print(f"check-alignment: {len(missing)} of {units} C++ translation units do not read {guard}, e.g.:")
    print("\n".join("  " + m for m in missing[:8]))
    sys.exit(1)
print(f"check-alignment: the guard fires and all {units} C++ translation units read it")
PY
