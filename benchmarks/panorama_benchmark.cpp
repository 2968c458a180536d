// Time and peak memory to build one panorama (paper §4.2, Table 6 / Fig. 8): office SO-1, three
// 640x480 cameras, ground-truth poses, Handa noise, H = 1024; warping and optimisation timed
// apart, and the TSDF baseline (Open3D, 5 mm voxels, 6 cm truncation) on the same frames.
//
//   build/benchmarks/panorama_benchmark                                  # every 16th frame
//   PANORAMA_BENCH_EVERY=1 build/benchmarks/panorama_benchmark           # every frame (heavy: ~3.6 GB of measurements)
//   build/benchmarks/panorama_benchmark --benchmark_filter=Warp          # one part, for a clean peak-memory figure
//
// Counters: measurements, measurement_MiB (the CSR sets), peak_rss_MiB (the process's peak resident
// memory so far; for BM_PanoramaSize the peak while that size ran, see reset_peak_rss), frames.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <memory>

#include <benchmark/benchmark.h>

#include "panoscan/core/timer.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/recon/open3d_calls.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/tsdf_baseline.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "benchmark_main.h"

using namespace panoscan;

namespace {

int every() {
  const char* v = std::getenv("PANORAMA_BENCH_EVERY");
  return v ? std::max(1, std::atoi(v)) : 16;
}

// CPU time of the whole process (all threads), in seconds: on a shared machine the wall time of a
// phase follows the other processes' load, its CPU time much less.
double process_cpu_s() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// A "Vm...:" line of /proc/self/status (Linux), in MiB; -1 where there is none.
double status_mib(const std::string& key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind(key + ":", 0) == 0) return std::stod(line.substr(key.size() + 1)) / 1024.0;  // "VmHWM:  123 kB"
  return -1.0;
}

// The process's peak resident memory: VmHWM, which reset_peak_rss() lowers to the current size;
// getrusage's ru_maxrss where there is no /proc.
double peak_rss_mib() {
  const double hwm = status_mib("VmHWM");
  if (hwm >= 0) return hwm;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return double(usage.ru_maxrss) / 1024.0;
}

// The process's resident memory now (VmRSS; 0 where there is no /proc).
double resident_mib() { return std::max(0.0, status_mib("VmRSS")); }

// Linux: sets the peak resident memory to the current one (/proc/self/clear_refs, "5"), so that
// peak_rss_mib() afterwards is the peak of what ran since, not of the benchmarks before it.
bool reset_peak_rss() {
  std::ofstream clear_refs("/proc/self/clear_refs");
  if (!clear_refs) return false;
  clear_refs << "5";
  return bool(clear_refs.flush());
}

// The measurements that BM_PanoramaFuse's variants share (warped once). BM_PanoramaSize, which runs
// after them, drops them: its peak memory is then its own run's plus the scan's index.
std::unique_ptr<PanoramaMeasurements>& fuse_measurements() {
  static std::unique_ptr<PanoramaMeasurements> m;
  return m;
}

struct BenchScan {
  std::filesystem::path dir;
  ScanIndex index;
  RigTrajectory truth;
  ~BenchScan() {
    std::error_code ignored;
    std::filesystem::remove_all(dir, ignored);
  }
};

const BenchScan& bench_scan() {
  static const std::unique_ptr<BenchScan> scan = [] {
    auto s = std::make_unique<BenchScan>();
    s->dir = std::filesystem::temp_directory_path() / ("panoscan-panorama-bench-" + std::to_string(::getpid()));
    const Scene scene = scenes::make_builtin_scene("office");
    SimOptions options;
    options.output.every = every();
    Simulator(scene, 0, options).write_scan(s->dir, true);
    s->index = read_scan_index(s->dir);
    s->truth = eval::groundtruth_rig_trajectory(s->dir);
    return s;
  }();
  return *scan;
}

void BM_PanoramaWarp(benchmark::State& state) {
  const BenchScan& scan = bench_scan();
  WarpOptions options;
  options.height = 1024;
  std::size_t samples = 0, bytes = 0, frames = 0;
  for (auto _ : state) {
    const PanoramaMeasurements m = warp_frames(scan.index, scan.truth, options);
    samples = m.samples.size();
    bytes = m.memory_bytes();
    frames = m.frames_used;
  }
  state.counters["measurements"] = double(samples);
  state.counters["measurement_MiB"] = double(bytes) / 1048576.0;
  state.counters["frames"] = double(frames);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}

void BM_PanoramaFuse(benchmark::State& state) {
  const BenchScan& scan = bench_scan();
  WarpOptions warp;
  warp.height = 1024;
  std::unique_ptr<PanoramaMeasurements>& m = fuse_measurements();
  if (!m) m = std::make_unique<PanoramaMeasurements>(warp_frames(scan.index, scan.truth, warp));
  FusionOptions fusion;
  fusion.method = DepthFusionMethod(state.range(0));
  std::size_t iterations = 0;
  double ratio = 0.0;
  for (auto _ : state) {
    const Panorama p = fuse(*m, fusion);
    iterations = p.energy.empty() ? 0 : p.energy.size() - 1;
    if (!p.energy.empty() && p.energy.back().smoothness_weighted > 0)
      ratio = p.energy.back().data / p.energy.back().smoothness_weighted;
  }
  state.counters["data_over_smoothness"] = ratio;
  state.SetLabel(to_string(fusion.method));
  state.counters["solver_iterations"] = double(iterations);
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}

// Growth with the panorama size: warping and TSA-L1 optimisation of the same frames at H = 256 ...
// 2048 (W = 2H). The warping's time follows the frames' pixels; the optimisation's follows the
// panorama's pixels.
void BM_PanoramaSize(benchmark::State& state) {
  const BenchScan& scan = bench_scan();
  WarpOptions warp;
  warp.height = int(state.range(0));
  FusionOptions fusion;
  fusion.method = DepthFusionMethod::kTsa;
  double warp_s = 0, fuse_s = 0, warp_cpu_s = 0, fuse_cpu_s = 0;
  std::size_t iterations = 0;
  fuse_measurements().reset();
  const double resident_before = resident_mib();
  const bool peak_is_this_run = reset_peak_rss();
  for (auto _ : state) {
    const double c0 = process_cpu_s();
    const auto t0 = std::chrono::steady_clock::now();
    const PanoramaMeasurements m = warp_frames(scan.index, scan.truth, warp);
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = process_cpu_s();
    const Panorama p = fuse(m, fusion);
    const auto t2 = std::chrono::steady_clock::now();
    const double c2 = process_cpu_s();
    warp_s = seconds_between(t0, t1);
    fuse_s = seconds_between(t1, t2);
    warp_cpu_s = c1 - c0;
    fuse_cpu_s = c2 - c1;
    iterations = p.energy.empty() ? 0 : p.energy.size() - 1;
  }
  state.counters["pixels"] = 2.0 * double(warp.height) * double(warp.height);
  state.counters["warp_s"] = warp_s;
  state.counters["fuse_s"] = fuse_s;
  // Per-phase process CPU time (all threads): CPU / 2 estimates the wall time on 2 idle cores.
  state.counters["warp_cpu_s"] = warp_cpu_s;
  state.counters["fuse_cpu_s"] = fuse_cpu_s;
  state.counters["solver_iterations"] = double(iterations);
  // The peak while this size ran (where the kernel lets the peak be reset; else the process's),
  // and what the process held before it (the simulated scan's index, the libraries).
  state.counters["peak_rss_MiB"] = peak_rss_mib();
  state.counters["peak_is_this_run"] = peak_is_this_run ? 1.0 : 0.0;
  state.counters["resident_before_MiB"] = resident_before;
}

void BM_TsdfBaseline(benchmark::State& state) {
  const BenchScan& scan = bench_scan();
  open3d_calls::load();  // loading Open3D (once per process) is not the TSDF's time
  TsdfResult result;
  for (auto _ : state) result = build_tsdf_baseline(scan.index, scan.truth, TsdfOptions{});
  state.counters["integrate_s"] = result.integrate_seconds;
  state.counters["extract_s"] = result.extract_seconds;
  state.counters["volume_MiB_estimate"] = double(result.memory_bytes) / 1048576.0;
  state.counters["peak_rss_MiB"] = peak_rss_mib();
}

}  // namespace

// Wall time and the whole process's CPU time (TBB's worker threads included): on a shared machine
// CPU / cores is the better estimate of the wall time on idle cores.
BENCHMARK(BM_PanoramaWarp)->Unit(benchmark::kSecond)->Iterations(1)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_PanoramaFuse)
    ->Arg(int(DepthFusionMethod::kAverage))
    ->Arg(int(DepthFusionMethod::kTvCylindrical))
    ->Arg(int(DepthFusionMethod::kTsa))
    ->Arg(int(DepthFusionMethod::kTp))
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_PanoramaSize)
    ->RangeMultiplier(2)
    ->Range(256, 2048)
    ->Unit(benchmark::kSecond)
    ->Iterations(1)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_TsdfBaseline)->Unit(benchmark::kSecond)->Iterations(1)->MeasureProcessCPUTime()->UseRealTime();

int main(int argc, char** argv) { return panoscan::bench::run_benchmarks(argc, argv); }
