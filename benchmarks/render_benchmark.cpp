// Renderer speed against bare Embree on the same rays, in the same run (docs/ARCHITECTURE.md §14.2: report ratios),
// and the time and disk size of one full simulated scanning position.
//
//   build/benchmarks/render_benchmark                       # all
//   build/benchmarks/render_benchmark --benchmark_filter=Rays   # the ratio only
#include <filesystem>

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"

using namespace panoscan;
namespace fs = std::filesystem;

namespace {

const Scene& office() {
  static const Scene scene = scenes::make_builtin_scene("office");
  return scene;
}

SimOptions full_size_options() {
  SimOptions options;  // 640x480, handa noise, three cameras
  return options;
}

// Poses all around position 1 for the three cameras: the rays the simulator casts.
std::vector<Rigid3d> view_poses(const Simulator& sim, int count) {
  std::vector<Rigid3d> poses;
  for (int i = 0; i < count; ++i) {
    const int c = i % 3;
    const auto& frames = sim.schedule()[c];
    poses.push_back(sim.world_from_cam(c, frames[(i * 37) % frames.size()].timestamp));
  }
  return poses;
}

// Bare Embree over the same rays as the full render: `intersect` is the renderer's single-ray or
// packet loop over a block of rows.
template <typename Intersect>
void bare_embree(benchmark::State& state, Intersect intersect) {
  const Simulator sim(office(), 0, full_size_options());
  const auto poses = view_poses(sim, 30);
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  std::size_t view = 0, hits = 0;
  for (auto _ : state) {
    const Rigid3d& pose = poses[view++ % poses.size()];
    hits += tbb::parallel_reduce(
        tbb::blocked_range<int>(0, k.height, 8), std::size_t(0),
        [&](const tbb::blocked_range<int>& rows, std::size_t sum) {
          return sum + intersect(sim.renderer(), pose, k, rows.begin(), rows.end());
        },
        std::plus<>());
  }
  benchmark::DoNotOptimize(hits);
  state.counters["rays_per_s"] =
      benchmark::Counter(double(state.iterations()) * k.width * k.height, benchmark::Counter::kIsRate);
}

void BM_RaysBareEmbree(benchmark::State& state) {
  bare_embree(state, [](const Renderer& r, const Rigid3d& pose, const PinholeIntrinsics& k, int begin, int end) {
    return r.intersect_only(pose, k, begin, end);
  });
}

void BM_RaysBareEmbreePackets(benchmark::State& state) {
  bare_embree(state, [](const Renderer& r, const Rigid3d& pose, const PinholeIntrinsics& k, int begin, int end) {
    return r.intersect_only_packets(pose, k, begin, end);
  });
}

// Depth + colour + normals + ids + Handa noise + exposure: everything but the PNG files.
void BM_RaysFullRender(benchmark::State& state) {
  const Simulator sim(office(), 0, full_size_options());
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  std::size_t i = 0;
  for (auto _ : state) {
    const int c = int(i % 3);
    const auto& frames = sim.schedule()[c];
    const SimulatedFrame frame = sim.render_frame(frames[(i * 37) % frames.size()]);
    benchmark::DoNotOptimize(frame.depth.data.data());
    ++i;
  }
  state.counters["rays_per_s"] =
      benchmark::Counter(double(state.iterations()) * k.width * k.height, benchmark::Counter::kIsRate);
}

// One whole scanning position (3 x ~990 frames at 640x480) written to disk.
void BM_SimulateOnePosition(benchmark::State& state) {
  SimOptions options = full_size_options();
  options.output.every = int(state.range(0));
  const Simulator sim(office(), 0, options);
  const fs::path out = fs::temp_directory_path() / "panoscan-bench-scan";
  double bytes = 0, frames = 0;
  for (auto _ : state) {
    frames = double(sim.write_scan(out, true));
    state.PauseTiming();
    bytes = 0;
    for (const auto& entry : fs::recursive_directory_iterator(out))
      if (entry.is_regular_file()) bytes += double(entry.file_size());
    state.ResumeTiming();
  }
  fs::remove_all(out);
  state.counters["frames"] = frames;
  state.counters["disk_MB"] = bytes / 1e6;
}

}  // namespace

BENCHMARK(BM_RaysBareEmbree)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_RaysBareEmbreePackets)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_RaysFullRender)->Unit(benchmark::kMillisecond)->MinTime(2.0)->UseRealTime();
BENCHMARK(BM_SimulateOnePosition)->Arg(1)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

BENCHMARK_MAIN();
