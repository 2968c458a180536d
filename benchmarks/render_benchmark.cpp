// Renderer speed against bare Embree on the same rays, in the same run (docs/ARCHITECTURE.md §14.2: report ratios),
// and a whole simulated scanning position end to end (PNG files included) with its stage breakdown.
// The Rays benchmarks also measure the process's CPU time (the "CPU" column): on a machine shared
// with other work it compares variants better than the real time.
//
//   build/benchmarks/render_benchmark                           # all
//   build/benchmarks/render_benchmark --benchmark_filter=Rays   # the ray ratios only
#include <chrono>
#include <filesystem>

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "panoscan/core/random.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/noise.h"
#include "panoscan/sim/simulator.h"
#include "benchmark_main.h"

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

// One view of bare Embree over the same rays as the full render: `intersect` is the renderer's
// single-ray or packet loop over a block of rows. Returns the hits.
template <typename Intersect>
std::size_t bare_embree_view(const Simulator& sim, const Rigid3d& pose, Intersect intersect) {
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  return tbb::parallel_reduce(
      tbb::blocked_range<int>(0, k.height, 8), std::size_t(0),
      [&](const tbb::blocked_range<int>& rows, std::size_t sum) {
        return sum + intersect(sim.renderer(), pose, k, rows.begin(), rows.end());
      },
      std::plus<>());
}

template <typename Intersect>
void bare_embree(benchmark::State& state, Intersect intersect) {
  const Simulator sim(office(), 0, full_size_options());
  const auto poses = view_poses(sim, 30);
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  std::size_t view = 0, hits = 0;
  for (auto _ : state) hits += bare_embree_view(sim, poses[view++ % poses.size()], intersect);
  benchmark::DoNotOptimize(hits);
  state.counters["rays_per_s"] =
      benchmark::Counter(double(state.iterations()) * k.width * k.height, benchmark::Counter::kIsRate);
}

std::size_t packets8(const Renderer& r, const Rigid3d& pose, const PinholeIntrinsics& k, int begin, int end) {
  return r.intersect_only_packets(pose, k, begin, end);
}

// Rays per second of the 8-ray packet loop over about `seconds` of views: BM_SimEndToEnd's reference,
// measured right before and after the run it is compared with.
double packet_rate(const Simulator& sim, double seconds) {
  const auto poses = view_poses(sim, 30);
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  const auto start = std::chrono::steady_clock::now();
  std::size_t views = 0, hits = 0;
  double elapsed = 0;
  do {
    hits += bare_embree_view(sim, poses[views++ % poses.size()], packets8);
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  } while (elapsed < seconds);
  benchmark::DoNotOptimize(hits);
  return double(views) * k.width * k.height / elapsed;
}

void BM_RaysBareEmbree(benchmark::State& state) {
  bare_embree(state, [](const Renderer& r, const Rigid3d& pose, const PinholeIntrinsics& k, int begin, int end) {
    return r.intersect_only(pose, k, begin, end);
  });
}

void BM_RaysBareEmbreePackets(benchmark::State& state) { bare_embree(state, packets8); }

// Packets of 16, as the renderer traces them: how much of the renderer's speed is the wider packet.
void BM_RaysBareEmbreePackets16(benchmark::State& state) {
  bare_embree(state, [](const Renderer& r, const Rigid3d& pose, const PinholeIntrinsics& k, int begin, int end) {
    return r.intersect_only_packets16(pose, k, begin, end);
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

// The renderer alone (depth, colour, incidence, ids: rays and shading, no noise): the part of the
// full render that Embree's rate bounds. `rays_stage_rays_per_cpu_s`: its ray stage alone (setting up
// the 16-ray packets, intersecting them, copying the hits out) per second of its threads' time, to
// set against bare Embree's packet loop per second of CPU time.
void BM_RaysRenderOnly(benchmark::State& state) {
  const Simulator sim(office(), 0, full_size_options());
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  const auto poses = view_poses(sim, 30);
  std::size_t view = 0;
  RenderTimes times;
  for (auto _ : state) {
    const RenderedView rendered = sim.renderer().render(poses[view++ % poses.size()], k, RenderRequest{}, &times);
    benchmark::DoNotOptimize(rendered.depth.data.data());
  }
  const double pixels = double(state.iterations()) * k.width * k.height;
  state.counters["rays_per_s"] = benchmark::Counter(pixels, benchmark::Counter::kIsRate);
  state.counters["rays_stage_rays_per_cpu_s"] = pixels / (1e-9 * double(times.rays_ns.load()));
  state.counters["shading_stage_share"] =
      double(times.shading_ns.load()) / double(times.rays_ns.load() + times.shading_ns.load());
}

// The Handa depth noise alone on one rendered 640x480 view (its normal draws and the model; all
// threads), a new frame index each time: process CPU ns per pixel in the "CPU" column's terms.
void BM_DepthNoise(benchmark::State& state) {
  const Simulator sim(office(), 0, full_size_options());
  const PinholeIntrinsics& k = sim.rig().intrinsics;
  const RenderedView view = sim.renderer().render(view_poses(sim, 1).front(), k);
  DepthNoiseInput input;
  input.clean_depth = &view.depth;
  input.incidence_cos = &view.incidence_cos;
  input.intrinsics = &k;
  for (auto _ : state) {
    const ImageF32 noisy = apply_depth_noise(input, sim.options().noise, sim.options().seed);
    benchmark::DoNotOptimize(noisy.data.data());
    ++input.frame;
  }
  state.counters["pixels_per_s"] =
      benchmark::Counter(double(state.iterations()) * k.width * k.height, benchmark::Counter::kIsRate);
}

// The depth noise's normal deviates as the simulator draws them (a bulk stream per row, a 640-pixel
// row's shift draws each: 1280 deviates), on one thread: ns per deviate.
void BM_DrawNormals(benchmark::State& state) {
  constexpr std::size_t kDraws = 1280;
  std::vector<double> row(kDraws);
  std::int64_t frame = 0;
  for (auto _ : state) {
    BulkNormalStream(1, 0, frame / 480, RandomPurpose::kDepthShift, frame % 480).fill(kDraws, 0.5, row.data());
    benchmark::DoNotOptimize(row[kDraws - 1]);
    ++frame;
  }
  state.counters["ns_per_deviate"] = benchmark::Counter(double(state.iterations()) * kDraws * 1e-9,
                                                        benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

// One whole scanning position (3 x 990 frames at 640x480, default options) written to disk as
// `panoscan sim` writes it: frames x pixels per second (the speed report's ratio against bare
// Embree), the disk size, and the stage breakdown of SimStageTimes as counters (thread seconds;
// *_share: of the per-frame stages' sum).
void BM_SimEndToEnd(benchmark::State& state) {
  SimOptions options = full_size_options();
  options.output.max_frames = int(state.range(0));  // 0: the whole turn
  const Simulator sim(office(), 0, options);
  const fs::path out = fs::temp_directory_path() / "panoscan-bench-scan";
  double bytes = 0;
  SimStageTimes times;
  // The 8-ray packet reference right before and after the run: on a VM whose speed drifts by 10-20%
  // over minutes, BM_RaysBareEmbreePackets (run long before) made this ratio move with the drift.
  const double packets_before = packet_rate(sim, 5.0);  // outside the timed loop
  for (auto _ : state) {
    sim.write_scan(out, true, &times);
    state.PauseTiming();
    bytes = 0;
    for (const auto& entry : fs::recursive_directory_iterator(out))
      if (entry.is_regular_file()) bytes += double(entry.file_size());
    state.ResumeTiming();
  }
  const double packets_after = packet_rate(sim, 5.0);
  state.counters["packets8_rays_per_s"] = 0.5 * (packets_before + packets_after);
  state.counters["packets8_after_over_before"] = packets_after / packets_before;
  fs::remove_all(out);
  state.counters["frames"] = double(times.frames);
  state.counters["disk_MB"] = bytes / 1e6;
  state.counters["pixels_per_s"] =
      benchmark::Counter(double(state.iterations()) * double(times.pixels), benchmark::Counter::kIsRate);
  const std::pair<const char*, double> stages[] = {
      {"rays", times.rays_s},     {"shading", times.shading_s}, {"depth_noise", times.depth_noise_s},
      {"colour", times.colour_s}, {"encode", times.encode_s},   {"ground_truth", times.ground_truth_s},
      {"write", times.write_s}};
  double sum = 0;
  for (const auto& stage : stages) sum += stage.second;
  for (const auto& [name, seconds] : stages) {
    state.counters[std::string(name) + "_s"] = seconds;
    state.counters[std::string(name) + "_share"] = sum > 0 ? seconds / sum : 0.0;
  }
  state.counters["idle_or_other_s"] = times.frame_threads_s - sum;
  state.counters["probe_s"] = times.probe_s;
  state.counters["finish_s"] = times.finish_s;
}

}  // namespace

BENCHMARK(BM_RaysBareEmbree)->Unit(benchmark::kMillisecond)->MinTime(2.0)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_RaysBareEmbreePackets)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_RaysBareEmbreePackets16)
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK(BM_RaysFullRender)->Unit(benchmark::kMillisecond)->MinTime(2.0)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_DepthNoise)->Unit(benchmark::kMillisecond)->MinTime(1.0)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK(BM_DrawNormals)->MinTime(1.0);
BENCHMARK(BM_RaysRenderOnly)->Unit(benchmark::kMillisecond)->MinTime(2.0)->MeasureProcessCPUTime()->UseRealTime();
// Replaces BM_SimulateOnePosition (the same whole position, without the rate and the stages).
BENCHMARK(BM_SimEndToEnd)->Arg(0)->Unit(benchmark::kSecond)->Iterations(1)->UseRealTime();

int main(int argc, char** argv) { return panoscan::bench::run_benchmarks(argc, argv); }
