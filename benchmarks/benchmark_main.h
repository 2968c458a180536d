// The main() of every PanoScan benchmark: the process set up as the panoscan command sets itself up
// (core/process.h), so that a benchmark measures what the program does, then Google Benchmark's
// own main.
#pragma once

#include <benchmark/benchmark.h>

#include "panoscan/core/process.h"

namespace panoscan::bench {

inline int run_benchmarks(int argc, char** argv) {
  set_up_process(argv);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace panoscan::bench
