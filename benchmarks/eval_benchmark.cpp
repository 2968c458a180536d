// Speed of the exact cloud-to-mesh distance (Embree point queries + exact point-triangle
// distance) on the built-in office mesh refined to >= 100k triangles, against, in the same run:
//   - brute force over all triangles (exact, O(triangles) per point; timed on a subset), and
//   - the sampled-mesh shortcut (PCL-style kd-tree over a dense area-uniform sampling, here
//     nanoflann): its speed and its error against the exact distances.
// The cloud: 1 million points = surface samples displaced by N(0, 5 mm) noise, plus 1% outliers.
//
//   build/benchmarks/eval_benchmark
//   build/benchmarks/eval_benchmark --benchmark_filter=Embree
#include <algorithm>
#include <chrono>
#include <cmath>

#include <benchmark/benchmark.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/timer.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/eval/cloud_metrics.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/eval/point_set_distance.h"
#include "panoscan/eval/surface_sampling.h"
#include "panoscan/scenes/scenes.h"
#include "benchmark_main.h"

using namespace panoscan;
using namespace panoscan::eval;

namespace {

constexpr std::size_t kCloudPoints = 1000000;
constexpr std::size_t kMinTriangles = 100000;

// Splits every triangle into four (edge midpoints) until the mesh has at least `min_triangles`.
TriangleMesh refine(TriangleMesh mesh, std::size_t min_triangles) {
  while (mesh.triangles.size() < min_triangles) {
    TriangleMesh finer;
    finer.vertices = mesh.vertices;
    for (const Eigen::Vector3i& t : mesh.triangles) {
      int mid[3];
      for (int k = 0; k < 3; ++k) {
        mid[k] = int(finer.vertices.size());
        finer.vertices.push_back(0.5f * (mesh.vertices[t[k]] + mesh.vertices[t[(k + 1) % 3]]));
      }
      finer.triangles.emplace_back(t[0], mid[0], mid[2]);
      finer.triangles.emplace_back(mid[0], t[1], mid[1]);
      finer.triangles.emplace_back(mid[2], mid[1], t[2]);
      finer.triangles.emplace_back(mid[0], mid[1], mid[2]);
    }
    mesh = std::move(finer);
  }
  return mesh;
}

struct Fixture {
  TriangleMesh mesh;
  std::unique_ptr<MeshDistance> distance;
  double bvh_seconds = 0.0;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> exact;  // exact distances of `points`
};

const Fixture& fixture() {
  static const Fixture* instance = [] {
    auto* f = new Fixture;
    const Scene office = scenes::make_builtin_scene("office");
    f->mesh = refine(office.mesh, kMinTriangles);
    const auto start = std::chrono::steady_clock::now();
    f->distance = std::make_unique<MeshDistance>(f->mesh, "office (refined)");
    f->bvh_seconds = seconds_since(start);
    const std::vector<SurfaceSample> samples = sample_surface_uniform(f->mesh, kCloudPoints, 2024);
    Eigen::Vector3f lo = f->mesh.vertices[0], hi = lo;
    for (const auto& v : f->mesh.vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
    f->points.resize(kCloudPoints);
    RandomStream random(2024, 0, 0, RandomPurpose::kGeneric, 1);
    for (std::size_t i = 0; i < kCloudPoints; ++i) {
      if (i % 100 == 99) {  // outlier anywhere in the bounding box
        for (int k = 0; k < 3; ++k) f->points[i][k] = random.uniform(lo[k], hi[k]);
      } else {
        f->points[i] = samples[i].point + 0.005 * Eigen::Vector3d(random.normal(), random.normal(), random.normal());
      }
    }
    f->exact = f->distance->distances(f->points);
    return f;
  }();
  return *instance;
}

void BM_BuildEmbreeBvh(benchmark::State& state) {
  const Fixture& f = fixture();
  for (auto _ : state) {
    MeshDistance distance(f.mesh);
    benchmark::DoNotOptimize(distance.surface_area());
  }
  state.counters["triangles"] = double(f.mesh.triangles.size());
}

// The exact distance of every point (the evaluation's hot loop).
void BM_ExactDistanceEmbree(benchmark::State& state) {
  const Fixture& f = fixture();
  std::size_t done = 0;
  for (auto _ : state) {
    const std::vector<double> d = f.distance->distances(f.points);
    benchmark::DoNotOptimize(d.data());
    done += d.size();
  }
  state.counters["points_per_s"] = benchmark::Counter(double(done), benchmark::Counter::kIsRate);
  state.counters["triangles"] = double(f.mesh.triangles.size());
  state.counters["rmse_mm"] = 1e3 * summarize_errors(f.exact).rmse;
}

// Brute force over all triangles, in parallel, on a subset of the points; also checks agreement.
void BM_ExactDistanceBruteForce(benchmark::State& state) {
  const Fixture& f = fixture();
  const std::size_t subset = 200;
  std::vector<double> d(subset);
  std::size_t done = 0;
  double worst_disagreement = 0.0;
  for (auto _ : state) {
    tbb::parallel_for(std::size_t(0), subset, [&](std::size_t i) {
      d[i] = closest_point_brute_force(f.mesh, f.points[i * (kCloudPoints / subset)]).distance;
    });
    done += subset;
  }
  for (std::size_t i = 0; i < subset; ++i)
    worst_disagreement = std::max(worst_disagreement, std::abs(d[i] - f.exact[i * (kCloudPoints / subset)]));
  state.counters["points_per_s"] = benchmark::Counter(double(done), benchmark::Counter::kIsRate);
  state.counters["max_diff_vs_embree_m"] = worst_disagreement;
}

// The sampled-mesh shortcut: distance to the nearest of `samples_per_m2` area-uniform samples.
// Its error is always >= 0 (a sample is never closer than the surface) and grows with spacing.
void BM_SampledMeshKdTree(benchmark::State& state) {
  const Fixture& f = fixture();
  const double samples_per_m2 = double(state.range(0));
  const auto build_start = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> sample_points;
  for (const SurfaceSample& s :
       sample_surface_uniform(f.mesh, std::size_t(f.distance->surface_area() * samples_per_m2), 99))
    sample_points.push_back(s.point);
  const PointSetDistance index(std::move(sample_points));
  const double build_seconds = seconds_since(build_start);
  std::vector<double> sampled;
  std::size_t done = 0;
  for (auto _ : state) {
    sampled = index.nearest_distances(f.points);
    done += sampled.size();
  }
  std::vector<double> error(sampled.size());
  for (std::size_t i = 0; i < sampled.size(); ++i) error[i] = sampled[i] - f.exact[i];
  const ErrorStats error_stats = summarize_errors(error);
  state.counters["points_per_s"] = benchmark::Counter(double(done), benchmark::Counter::kIsRate);
  state.counters["samples"] = double(index.size());
  state.counters["build_s"] = build_seconds;
  state.counters["err_mean_mm"] = 1e3 * error_stats.mean;
  state.counters["err_p99_mm"] = 1e3 * error_stats.p99;
  state.counters["err_max_mm"] = 1e3 * error_stats.max;
  state.counters["rmse_exact_mm"] = 1e3 * summarize_errors(f.exact).rmse;
  state.counters["rmse_sampled_mm"] = 1e3 * summarize_errors(sampled).rmse;
}

// The whole cloud evaluation: accuracy plus completeness (default density, no viewpoints).
void BM_EvaluateCloudWithCompleteness(benchmark::State& state) {
  const Fixture& f = fixture();
  PointCloud cloud;
  cloud.positions = f.points;
  CloudMetricsOptions options;
  CloudMetrics metrics;
  for (auto _ : state) metrics = evaluate_cloud(*f.distance, cloud, "benchmark", options);
  state.counters["accuracy_s"] = metrics.seconds_accuracy;
  state.counters["completeness_s"] = metrics.seconds_completeness;
  state.counters["samples"] = double(metrics.surface_samples);
  state.counters["F_1cm"] = metrics.scores[0].f_score;
}

}  // namespace

BENCHMARK(BM_BuildEmbreeBvh)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_ExactDistanceEmbree)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_ExactDistanceBruteForce)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_SampledMeshKdTree)->Arg(10000)->Arg(40000)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);
BENCHMARK(BM_EvaluateCloudWithCompleteness)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

int main(int argc, char** argv) { return panoscan::bench::run_benchmarks(argc, argv); }
