# Build time (issue 37, part 6; measurements in docs/build.md).
#
# Precompiled headers: one per kind of target, built once and reused (REUSE_FROM) by every
# target of that kind with the same flags: the 14 stage libraries, the test executables, the CLI,
# the Python module. Each holds only third-party and standard headers (never a hazmap header, so
# the stage layering that cmake/stages.cmake enforces is untouched). The code generated is the
# same: no flag changes, only what the parser reads first.
#
# A GCC precompiled header is not byte-identical from one build folder to the next, so with
# ccache each worktree would miss on every file compiled against its own PCH: where ccache is in
# use (a developer's machine, a cache shared by worktrees) it is the better of the two and PCH
# stays off by default; on a fresh machine (CI) PCH is on. -DHAZMAP_PCH=ON/OFF overrides.
# (HAZMAP_PCH is decided in the root CMakeLists.txt, next to the ccache launcher.)
if(NOT HAZMAP_PCH)
  return()
endif()

# Standard and Eigen headers that most translation units include (counted over src/, apps/,
# tests/: cmath 109 files, vector 87, string 85, algorithm 76, filesystem 48, Eigen/Geometry 39...).
set(HAZMAP_PCH_COMMON ${HAZMAP_ALIGNMENT_GUARD}
  <algorithm> <array> <cmath> <cstddef> <cstdint> <cstdio> <cstring> <filesystem> <fstream>
  <functional> <limits> <map> <memory> <optional> <sstream> <string> <string_view>
  <unordered_map> <utility> <vector> <Eigen/Core> <Eigen/Geometry>)

# Stage libraries: all compiled with the same flags and definitions (cmake/stages.cmake).
list(GET HAZMAP_STAGE_TARGETS 0 HAZMAP_PCH_STAGE_OWNER)
target_precompile_headers(${HAZMAP_PCH_STAGE_OWNER} PRIVATE ${HAZMAP_PCH_COMMON})
foreach(target ${HAZMAP_STAGE_TARGETS})
  if(NOT target STREQUAL HAZMAP_PCH_STAGE_OWNER)
    target_precompile_headers(${target} REUSE_FROM ${HAZMAP_PCH_STAGE_OWNER})
  endif()
endforeach()

# The CLI: CLI11 is header-only and the heaviest header we include (~5 s of CPU per file alone).
target_precompile_headers(hazmap_cli PRIVATE ${HAZMAP_PCH_COMMON} <CLI/CLI.hpp>
  <nlohmann/json.hpp> <fmt/format.h>)

# Test executables (tests/test_<name>.cpp, one each, same flags): GoogleTest on top.
if(HAZMAP_BUILD_TESTS)
  get_property(hazmap_test_targets DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/tests PROPERTY BUILDSYSTEM_TARGETS)
  set(HAZMAP_PCH_TEST_OWNER)
  foreach(target ${hazmap_test_targets})
    get_target_property(type ${target} TYPE)
    if(NOT type STREQUAL "EXECUTABLE" OR NOT target MATCHES "^test_")
      continue()
    endif()
    if(NOT HAZMAP_PCH_TEST_OWNER)
      set(HAZMAP_PCH_TEST_OWNER ${target})
      target_precompile_headers(${target} PRIVATE ${HAZMAP_PCH_COMMON} <gtest/gtest.h>)
    else()
      target_precompile_headers(${target} REUSE_FROM ${HAZMAP_PCH_TEST_OWNER})
    endif()
  endforeach()
endif()

# The Python module (its own flags: pybind11's visibility and LTO).
if(TARGET _hazmap)
  target_precompile_headers(_hazmap PRIVATE ${HAZMAP_PCH_COMMON} <pybind11/pybind11.h>
    <pybind11/stl.h> <pybind11/numpy.h> <pybind11/eigen.h>)
endif()

# Every other compiled target (fuzz replay, benchmarks, helpers) reads the alignment guard from
# its command line: a PCH-less file must not escape it (cmake/alignment_guard.hpp).
function(hazmap_guard_targets_without_pch dir)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(target ${targets})
    get_target_property(type ${target} TYPE)
    if(NOT type MATCHES "EXECUTABLE|LIBRARY" OR type STREQUAL "INTERFACE_LIBRARY")
      continue()
    endif()
    get_target_property(own ${target} PRECOMPILE_HEADERS)
    get_target_property(reused ${target} PRECOMPILE_HEADERS_REUSE_FROM)
    if(NOT own AND NOT reused)
      target_compile_options(${target} PRIVATE "$<$<COMPILE_LANGUAGE:CXX>:--include=${HAZMAP_ALIGNMENT_GUARD}>")
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub ${subdirs})
    hazmap_guard_targets_without_pch(${sub})
  endforeach()
endfunction()
hazmap_guard_targets_without_pch(${CMAKE_CURRENT_SOURCE_DIR})
