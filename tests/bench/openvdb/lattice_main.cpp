// gvd_bench_openvdb: the 64-sphere lattice through gvd and through OpenVDB's meshToVolume,
// side by side, in a process of its own (OpenVDB and TBB, once loaded, would add their
// resident memory to every gvd_bench row's peak).

#include <benchmark/benchmark.h>
#include <malloc.h>

#include "bench/sphere_lattice.h"

int main(int argc, char** argv) {
  // As gvd_bench and the gvd command line: freed big blocks stay in the heap.
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  gvd::bench::register_sphere_lattice_benchmarks();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  gvd::bench::print_sphere_lattice_summary();
  return 0;
}
