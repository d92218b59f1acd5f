// gvd_bench_openvdb: the 64-sphere lattice through gvd and through OpenVDB's meshToVolume,
// side by side, in a process of its own (OpenVDB and TBB, once loaded, would add their
// resident memory to every gvd_bench row's peak).

#include <benchmark/benchmark.h>

#include "bench/sphere_lattice.h"
#include "gvd/common/peak_memory.h"

int main(int argc, char** argv) {
  // The heap policy of the gvd command line and server.
  gvd::use_returning_heap();
  gvd::bench::register_sphere_lattice_benchmarks();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  gvd::bench::print_sphere_lattice_summary();
  return 0;
}
