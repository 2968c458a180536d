// Registration speed (Table 4 methods) against Open3D's and PCL's GICP on the same clouds, same run.
//   build/benchmarks/registration_benchmark
#include <map>

#include <benchmark/benchmark.h>

#include "panoscan/recon/outside_references.h"
#include "panoscan/recon/point_covariance.h"
#include "panoscan/recon/registration.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/renderer.h"

using namespace panoscan;

namespace {

struct Pair {
  RegistrationCloud source, target;
  Rigid3d initial;
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
    for (int v = 0; v < pano.height; ++v)
      for (int u = 0; u < pano.width(); ++u) {
        const double z = view.depth.at(u, v);
        if (z <= 0) continue;
        cloud.points.push_back(pano.direction(u, v) * z);
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
  Pair p{make(world_from_source), make(world_from_target), Rigid3d::Identity()};
  p.initial = make_rigid(so3_exp(Eigen::Vector3d(0.005, -0.01, 0.015)), Eigen::Vector3d(0.03, -0.02, 0.01)) *
              world_from_target.inverse() * world_from_source;
  return p;
}

// One pair per height, made on first use and kept for the process's lifetime.
const Pair& office_pair(int height = 256) {
  static std::map<int, Pair> pairs;
  auto it = pairs.find(height);
  if (it == pairs.end()) it = pairs.emplace(height, make_office_pair(height)).first;
  return it->second;
}

void BM_Register(benchmark::State& state) {
  const Pair& pair = office_pair();
  IcpOptions options;
  options.method = static_cast<IcpMethod>(state.range(0));
  state.SetLabel(to_string(options.method));
  int iterations = 0;
  for (auto _ : state) iterations = register_icp(pair.source, pair.target, pair.initial, options).iterations;
  state.counters["iterations"] = iterations;
  state.counters["points"] = double(pair.source.points.size());
}

void BM_RegisterOpen3dGicp(benchmark::State& state) {
  const Pair& pair = office_pair();
  for (auto _ : state)
    benchmark::DoNotOptimize(register_open3d_gicp(pair.source, pair.target, pair.initial, IcpOptions{}));
  state.counters["points"] = double(pair.source.points.size());
}

void BM_RegisterPclGicp(benchmark::State& state) {
  const Pair& pair = office_pair();
  for (auto _ : state)
    benchmark::DoNotOptimize(register_pcl_gicp(pair.source, pair.target, pair.initial, IcpOptions{}));
  state.counters["points"] = double(pair.source.points.size());
}

// Growth with the number of points: GICP (Ours) and Open3D's GICP (the reference, same clouds) on
// the pair at H = 128, 256, 512 (about 33k, 131k, 524k points). Argument 0: the height; 1: 0 = ours,
// 1 = Open3D. PCL's GICP is left out here: at 524k points it alone would take most of a minute.
void BM_RegisterGrowth(benchmark::State& state) {
  const int height = int(state.range(0));
  const bool reference = state.range(1) == 1;
  const Pair& pair = office_pair(height);
  IcpOptions options;
  options.method = IcpMethod::kGicpMeasured;
  state.SetLabel(reference ? "open3d-gicp" : to_string(options.method));
  for (auto _ : state) {
    if (reference)
      benchmark::DoNotOptimize(register_open3d_gicp(pair.source, pair.target, pair.initial, IcpOptions{}));
    else
      benchmark::DoNotOptimize(register_icp(pair.source, pair.target, pair.initial, options));
  }
  state.counters["points"] = double(pair.source.points.size());
}

void BM_PrepareSurface(benchmark::State& state) {
  RegistrationCloud cloud = office_pair().source;
  for (auto _ : state) prepare_surface(cloud, Eigen::Vector3d::Zero(), SurfaceOptions{});
  state.counters["points"] = double(cloud.points.size());
}

}  // namespace

BENCHMARK(BM_Register)->DenseRange(0, 6)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RegisterOpen3dGicp)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RegisterPclGicp)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RegisterGrowth)
    ->ArgsProduct({{128, 256, 512}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();
BENCHMARK(BM_PrepareSurface)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
