#pragma once
// Every benchmark runs with the allocator setting the hazmap CLI uses (see core/memory.hpp), so
// hazmap and its peers are timed in the same process conditions as a live run.
#include <benchmark/benchmark.h>

#include "hazmap/core/memory.hpp"

#define HAZMAP_BENCHMARK_MAIN()                 \
  int main(int argc, char** argv) {             \
    hazmap::retainFreedMemory();                \
    benchmark::Initialize(&argc, argv);         \
    benchmark::RunSpecifiedBenchmarks();        \
    benchmark::Shutdown();                      \
    return 0;                                   \
  }
