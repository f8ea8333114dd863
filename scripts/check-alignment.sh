#!/usr/bin/env bash
# Compile-only check that no std::stable_sort / std::stable_partition / std::inplace_merge works on
# an over-aligned element type (issue 37, part 4). libstdc++ (GCC 12) takes those algorithms'
# scratch buffer from plain ::operator new, 16-byte aligned; under -march=native Eigen aligns
# Isometry3d, Matrix4d, Vector4d, Quaterniond, Matrix<double,6,6>... to 32 or 64 bytes, and the
# compiler's aligned AVX stores into that buffer fault. In the default build those types need 16
# bytes, so the bug cannot show there: this pass makes it visible without a second build and
# without an AVX machine.
#
# Each translation unit that uses one of those algorithms (or includes a header of ours that does)
# is compiled with its own command from compile_commands.json plus -fsyntax-only,
# -march=x86-64-v4 (AVX-512, the strictest alignment Eigen uses; nothing runs, so any x86-64 CPU
# will do) and -include cmake/alignment_guard.hpp, whose static_assert names the offending call.
# A self-test first proves that the guard still fires (libstdc++'s internals could change).
#
#   scripts/check-alignment.sh <build dir>     exit 0 when clean; else the compiler's message, exit 1
#   CHECK_JOBS=n                               parallel compilers (default 2)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="$(cd "${1:?usage: scripts/check-alignment.sh <build dir>}" && pwd)"
db="$build/compile_commands.json"
[[ -f "$db" ]] || { echo "check-alignment: $db: missing (configure with CMAKE_EXPORT_COMPILE_COMMANDS)"; exit 1; }
flags=(-fsyntax-only -march=x86-64-v4 -include "$root/cmake/alignment_guard.hpp")
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

# Self-test: an Isometry3d in a stable_sort must be refused, a Vector3d (24 bytes) accepted.
cat > "$work/self_test.cpp" <<'EOF'
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
EOF
cxx="${CXX:-c++}"
if ! "$cxx" -std=c++20 -I/usr/include/eigen3 "${flags[@]}" "$work/self_test.cpp" 2> "$work/self.log"; then
  echo "check-alignment: self-test: the guard refuses a type it must accept:"; cat "$work/self.log"; exit 1
fi
if "$cxx" -std=c++20 -I/usr/include/eigen3 "${flags[@]}" -DHAZMAP_SELF_TEST_BAD "$work/self_test.cpp" \
     2> "$work/self.log" || ! grep -q "hazmap alignment check" "$work/self.log"; then
  echo "check-alignment: self-test: the guard no longer catches a stable_sort over an Eigen::Isometry3d"
  echo "  (libstdc++'s std::_Temporary_buffer changed?): fix cmake/alignment_guard.hpp"; exit 1
fi

# Headers of ours that use the algorithms; the Python below adds every TU that includes one.
pattern='stable_sort|stable_partition|inplace_merge'
mapfile -t headers < <(cd "$root" && grep -rlE "$pattern" include src apps python/src tests \
  --include='*.hpp' --include='*.h' || true)
names=()
for h in "${headers[@]}"; do names+=("$(basename "$h")"); done

python3 - "$db" "$root" "$pattern" "${CHECK_JOBS:-2}" "${flags[@]}" -- "${names[@]}" <<'EOF'
import concurrent.futures, json, os, re, shlex, subprocess, sys
db, root, pattern, jobs = sys.argv[1:5]
rest = sys.argv[5:]
flags, names = rest[:rest.index("--")], rest[rest.index("--") + 1:]
uses = re.compile(pattern)
incl = (re.compile(r'#\s*include\s*[<"][^>"]*\b(' + "|".join(map(re.escape, names)) + r')[>"]')
        if names else None)
units = []
for e in json.load(open(db)):
    src = e["file"]
    if not src.startswith(root + "/") or not src.endswith(".cpp"):
        continue
    text = open(src, errors="replace").read()
    if not (uses.search(text) or (incl and incl.search(text))):
        continue
    args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
    keep, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a in ("-o", "-MF", "-MT", "-MQ"):
            skip = True
        elif a not in ("-c", "-MD", "-MMD", src) and os.path.basename(a) != "ccache":
            keep.append(a)
    units.append((e["directory"], src, keep + flags + [src]))
if not units:
    sys.exit(f"check-alignment: no translation unit of {root} uses {pattern} (is {db} this tree's?)")

def check(unit):
    directory, src, cmd = unit
    r = subprocess.run(cmd, cwd=directory, capture_output=True, text=True)
    return src, r.returncode, r.stderr

failed = 0
with concurrent.futures.ThreadPoolExecutor(int(jobs)) as pool:
    for src, rc, err in pool.map(check, units):
        if rc != 0:
            failed += 1
            lines = [l for l in err.splitlines() if "error" in l or "required from here" in l]
            print(f"check-alignment: {os.path.relpath(src, root)}:")
            print("\n".join("  " + l for l in lines[:8]))
if failed:
    sys.exit(1)
print(f"check-alignment: {len(units)} translation units: no stable sort or merge over an "
      "over-aligned type")
EOF
