// Registration speed (Table 4 methods) against Open3D's and PCL's GICP on the same clouds, same run.
//   build/benchmarks/registration_benchmark
#include <chrono>
#include <map>

#include <benchmark/benchmark.h>

#include "panoscan/recon/open3d_calls.h"
#include "panoscan/recon/outside_references.h"
#include "panoscan/recon/point_covariance.h"
#include "panoscan/recon/registration.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/renderer.h"
#include "benchmark_main.h"

using namespace panoscan;

namespace {

struct Pair {
  RegistrationCloud source, target;
  Rigid3d initial, truth;  // target_from_source
};

// Office panoramas from SO-1 and SO-3 at height H (all valid pixels: ~130k points each at H = 256),
// with Handa-model measurement covariances; the initial guess is the truth perturbed by 1 deg / 3 cm.
Pair make_office_pair(int height) {
  const Scene scene = scenes::make_builtin_scene("office");
  const Renderer renderer(scene);
  const Equirectangular pano{height};
  auto make = [&](const Rigid3d& world_from_pano) {
    const RenderedView view = renderer.render_equirectangular(world_from_pano, pano);
    RegistrationCloud cloud;
    cloud.grid_width = pano.width();  // organised: prepare_surface's neighbours from the pixel window
    cloud.grid_height = pano.height;
    for (int v = 0; v < pano.height; ++v)
      for (int u = 0; u < pano.width(); ++u) {
        const double z = view.depth.at(u, v);
        if (z <= 0) continue;
        cloud.points.push_back(pano.direction(u, v) * z);
        cloud.grid_cells.push_back(std::uint32_t(v * pano.width() + u));
        cloud.measurement_covariances.push_back(
            equirectangular_point_covariance(2 * M_PI * (u + 0.5) / pano.width(), M_PI * (v + 0.5) / pano.height, z,
                                             0.5 * M_PI / pano.height, 9.49e-4 * z * z));
      }
    prepare_surface(cloud, Eigen::Vector3d::Zero(), SurfaceOptions{});
    return cloud;
  };
  const Rigid3d world_from_target =
      make_rigid(Eigen::Matrix3d::Identity(), scene.positions[0].floor_point + Eigen::Vector3d(0, 0, 1.1));
  const Rigid3d world_from_source =
      make_rigid(so3_exp(Eigen::Vector3d(0, 0, 0.7)), scene.positions[2].floor_point + Eigen::Vector3d(0, 0, 1.1));
  Pair p{make(world_from_source), make(world_from_target), Rigid3d::Identity(), Rigid3d::Identity()};
  p.truth = world_from_target.inverse() * world_from_source;
  p.initial = make_rigid(so3_exp(Eigen::Vector3d(0.005, -0.01, 0.015)), Eigen::Vector3d(0.03, -0.02, 0.01)) * p.truth;
  return p;
}

// One pair per height, made on first use and kept for the process's lifetime.
const Pair& office_pair(int height = 256) {
  static std::map<int, Pair> pairs;
  auto it = pairs.find(height);
  if (it == pairs.end()) it = pairs.emplace(height, make_office_pair(height)).first;
  return it->second;
}

// The result's distance from the true pose: the "same or lower error" half of the speed claim.
void report_error(benchmark::State& state, const Pair& pair, const IcpResult& result) {
  const Rigid3d error = pair.truth.inverse() * result.target_from_source;
  state.counters["error_mm"] = 1e3 * error.translation().norm();
  state.counters["error_mdeg"] = 1e3 * so3_log(error.linear()).norm() * 180.0 / M_PI;
  state.counters["points"] = double(pair.source.points.size());
}

// Per-phase seconds of one registration (the last of the benchmark's iterations).
void report_phases(benchmark::State& state, const IcpResult& result, double surface_s) {
  state.counters["iterations"] = result.iterations;
  state.counters["surface_s"] = surface_s;
  state.counters["setup_s"] = result.timings.setup_s;
  state.counters["correspondence_s"] = result.timings.correspondence_s;
  state.counters["linearise_s"] = result.timings.linearise_s;
  state.counters["solve_s"] = result.timings.solve_s;
}

void BM_Register(benchmark::State& state) {
  const Pair& pair = office_pair();
  IcpOptions options;
  options.method = static_cast<IcpMethod>(state.range(0));
  state.SetLabel(to_string(options.method));
  IcpResult result;
  for (auto _ : state) result = register_icp(pair.source, pair.target, pair.initial, options);
  report_error(state, pair, result);
  report_phases(state, result, 0.0);
}

void BM_RegisterOpen3dGicp(benchmark::State& state) {
  const Pair& pair = office_pair();
  open3d_calls::load();  // loading Open3D (once per process) is not its registration's time
  IcpResult result;
  for (auto _ : state) result = register_open3d_gicp(pair.source, pair.target, pair.initial, IcpOptions{});
  report_error(state, pair, result);
}

void BM_RegisterPclGicp(benchmark::State& state) {
  const Pair& pair = office_pair();
  IcpResult result;
  for (auto _ : state) result = register_pcl_gicp(pair.source, pair.target, pair.initial, IcpOptions{});
  report_error(state, pair, result);
}

// Growth with the number of points, on the pair at H = 128, 256, 512 (about 33k, 131k, 524k points).
// Argument 0: the height; 1: what runs on the same clouds:
//   0 GICP (Ours) on prepared clouds (the pipeline prepares each panorama once for all its pairs),
//   1 Open3D's GICP, 2 PCL's GICP (each estimates its covariances inside the call),
//   3 GICP (Ours) including prepare_surface() of both clouds: the like-for-like comparison,
//   4 the same with each point's neighbours from the kd-tree instead of its panorama window (the
//     clouds' grid_cells dropped): what the organised neighbourhood changes, in time and error.
void BM_RegisterGrowth(benchmark::State& state) {
  const int height = int(state.range(0));
  const int variant = int(state.range(1));
  const Pair& pair = office_pair(height);
  IcpOptions options;
  options.method = IcpMethod::kGicpMeasured;
  const char* labels[] = {"gicp-ours", "open3d-gicp", "pcl-gicp", "gicp-ours+surface", "gicp-ours+surface (kd-tree)"};
  state.SetLabel(labels[variant]);
  if (variant == 1) open3d_calls::load();  // loading Open3D (once per process) is not its registration's time
  IcpResult result;
  double surface_s = 0.0;
  for (auto _ : state) {
    if (variant == 1) {
      result = register_open3d_gicp(pair.source, pair.target, pair.initial, IcpOptions{});
    } else if (variant == 2) {
      result = register_pcl_gicp(pair.source, pair.target, pair.initial, IcpOptions{});
    } else if (variant == 3 || variant == 4) {
      state.PauseTiming();  // the copies are not part of the registration
      RegistrationCloud source = pair.source, target = pair.target;
      if (variant == 4) source.grid_cells.clear(), target.grid_cells.clear();
      state.ResumeTiming();
      const auto start = std::chrono::steady_clock::now();
      prepare_surface(source, Eigen::Vector3d::Zero(), SurfaceOptions{});
      prepare_surface(target, Eigen::Vector3d::Zero(), SurfaceOptions{});
      surface_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      result = register_icp(source, target, pair.initial, options);
    } else {
      result = register_icp(pair.source, pair.target, pair.initial, options);
    }
  }
  report_error(state, pair, result);
  if (variant == 0 || variant >= 3) report_phases(state, result, surface_s);
}

// Arguments: threads (1 = the per-core cost, 0 = all cores); 1 = neighbours from the panorama
// window (the cloud's grid_cells), 0 = from the kd-tree.
void BM_PrepareSurface(benchmark::State& state) {
  RegistrationCloud cloud = office_pair().source;
  if (state.range(1) == 0) cloud.grid_cells.clear();
  state.SetLabel(state.range(1) != 0 ? "grid window" : "kd-tree");
  SurfaceOptions options;
  options.threads = int(state.range(0));
  for (auto _ : state) prepare_surface(cloud, Eigen::Vector3d::Zero(), options);
  state.counters["points"] = double(cloud.points.size());
}

}  // namespace

BENCHMARK(BM_Register)->DenseRange(0, 6)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RegisterOpen3dGicp)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RegisterPclGicp)->Unit(benchmark::kMillisecond)->UseRealTime();
// Each instance repeated until it has run for at least 2 s, the mean of those runs reported: at 33k
// points ours takes 20-40 ms, and a disturbance of the VM during one run (a stall faulting in the
// surfaces' fresh pages) moved a ratio by 10-40%. With a single run that was session 41's two
// records (10.6 and 9.4x PCL at 33k points); with three, session 43's (14.2 and 9.0x). The slow
// references (seconds per run) still run once or twice.
BENCHMARK(BM_RegisterGrowth)
    ->ArgsProduct({{128, 256, 512}, {0, 1, 2, 3, 4}})
    ->Unit(benchmark::kMillisecond)
    ->MinTime(2.0)
    ->UseRealTime();
BENCHMARK(BM_PrepareSurface)
    ->Args({1, 1})
    ->Args({0, 1})
    ->Args({1, 0})
    ->Args({0, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

int main(int argc, char** argv) { return panoscan::bench::run_benchmarks(argc, argv); }
