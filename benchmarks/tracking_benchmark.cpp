// Speed of the joint tracking (paper Table 6: 4.3 ms per frame front end, 3.02 s tracking per
// panorama at n = 16 on a 6-core CPU). Simulated office SO-1 scans with Handa noise, rendered once
// per (resolution, n) into a temporary directory. Arguments: {width, n} (Solve: {width, n, solver}).
//   tracking_benchmark --benchmark_filter=Frontend      front end ms per frame (counter ms_per_frame),
//                                                       matched by projection and brute force
//   tracking_benchmark --benchmark_filter=Solve         factor graph per panorama, against n
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include <unistd.h>

#include "panoscan/core/scan.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/eval/trajectory_metrics.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "benchmark_main.h"

namespace panoscan {
namespace {

constexpr int kThreads = 2;

const ScanIndex& scan_for(int width, int every) {
  static std::map<std::pair<int, int>, ScanIndex> scans;
  static const Scene scene = scenes::make_builtin_scene("office");
  const auto key = std::make_pair(width, every);
  if (auto it = scans.find(key); it != scans.end()) return it->second;
  SimOptions options;
  options.rig.width = width;
  options.rig.height = width * 3 / 4;
  options.output.every = every;
  options.seed = 3;
  options.threads = kThreads;
  const auto dir =
      std::filesystem::temp_directory_path() / ("panoscan-tracking-benchmark-" + std::to_string(::getpid()) + "-" +
                                                std::to_string(width) + "-" + std::to_string(every));
  Simulator(scene, 0, options).write_scan(dir, true);
  return scans[key] = read_scan_index(dir);
}

TrackingOptions benchmark_options() {
  TrackingOptions options;
  options.threads = kThreads;
  options.frontend.threads = kThreads;
  return options;
}

// Third argument: 1 = same-camera and loop pairs matched by projection (frontend.guided_matching,
// the default), 0 = brute force, the reference in the same run.
void BM_Frontend(benchmark::State& state) {
  const ScanIndex& scan = scan_for(int(state.range(0)), int(state.range(1)));
  std::size_t frames = 0;
  for (const auto& f : scan.frames) frames += f.size();
  FrontendOptions options = benchmark_options().frontend;
  options.guided_matching = state.range(2) != 0;
  options.orb_levels = int(state.range(3));  // 0 = by the scan's motion (3 on the rotator), as recon track
  // As recon track's default runs it: with the depth odometry on, the front end also keeps each
  // frame's depth grid (track_scan sets this).
  const TrackingOptions defaults;
  options.depth_grid_block = defaults.depth_odometry ? defaults.depth_odometry_block_px : 0;
  state.SetLabel(std::string(options.guided_matching ? "matched by projection" : "brute-force matching") +
                 (options.orb_levels > 0 ? ", " + std::to_string(options.orb_levels) + " ORB levels" : ""));
  double ms = 0, warm_ms = 0, feature_ms = 0, matching_ms = 0, landmarks = 0;
  for (auto _ : state) {
    // The figures are the first run's, as a recon track process has it: every page the front end
    // keeps (features, crops, depth grids) is touched for the first time. The second run reuses
    // the first one's freed memory (warm_ms_per_frame): the difference is the first touches' cost.
    const FrontendResult result = run_frontend(scan, options);
    ms = 1e3 * result.total_seconds / double(frames);
    feature_ms = result.feature_ms_per_frame;    // decoding the frame, ORB, the overlap crops
    matching_ms = result.matching_ms_per_frame;  // pairs, RANSAC, cross-camera, landmarks
    landmarks = double(result.landmarks.size());
    warm_ms = 1e3 * run_frontend(scan, options).total_seconds / double(frames);
  }
  state.counters["frames"] = double(frames);
  state.counters["ms_per_frame"] = ms;
  state.counters["warm_ms_per_frame"] = warm_ms;
  state.counters["feature_ms_per_frame"] = feature_ms;
  state.counters["matching_ms_per_frame"] = matching_ms;
  state.counters["landmarks"] = landmarks;
}

// Fourth argument: 0 = the paper's graph (Eq. 1-3 with the shared wobble), 1 = recon track's default,
// which adds the depth odometry (its ICP time is the depth_odometry_s counter, outside solve_s; the
// front end keeps the depth grids, as track_scan has it do).
void BM_Solve(benchmark::State& state) {
  const ScanIndex& scan = scan_for(int(state.range(0)), int(state.range(1)));
  TrackingOptions options = benchmark_options();
  options.depth_odometry = state.range(3) != 0;
  FrontendOptions frontend_options = options.frontend;
  frontend_options.depth_grid_block = options.depth_odometry ? options.depth_odometry_block_px : 0;
  const FrontendResult frontend = run_frontend(scan, frontend_options);
  const char* solvers[] = {"sparse_schur", "sparse_normal_cholesky", "dense_schur", "iterative_schur"};
  options.linear_solver = solvers[state.range(2)];
  state.SetLabel(std::string(options.linear_solver) + (options.depth_odometry ? ", + depth odometry" : ", Eq. 1-3"));
  TrackingResult result;
  for (auto _ : state) result = track_with_frontend(scan, frontend, options);
  const TrackingStats& stats = result.stats;
  // The accuracy the speed is bought with: the mean over cameras of the ATE RMSE (mm).
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan.root);
  eval::TrajectoryMetricsOptions metrics_options;
  metrics_options.rpe_delta_s = 1.0;
  double ate_mm = 0;
  for (std::size_t s = 0; s < truth.world_from_cam.size(); ++s)
    ate_mm += 1e3 *
              eval::evaluate_trajectory(truth.world_from_cam[s], result.trajectory.world_from_cam[s], metrics_options,
                                        "truth", "tracked")
                  .ate_m.rmse /
              double(truth.world_from_cam.size());
  state.counters["ate_mm"] = ate_mm;
  state.counters["linear_solver_s"] = stats.linear_solver_seconds;
  state.counters["jacobian_s"] = stats.jacobian_seconds;
  state.counters["frames"] = stats.frames;
  state.counters["landmarks"] = stats.landmarks;
  state.counters["iterations"] = stats.iterations;
  state.counters["solve_s"] = stats.solve_seconds;
  state.counters["depth_odometry_s"] = stats.depth_odometry_seconds;
  state.counters["depth_pairs"] = stats.depth_pairs;
  state.counters["converged"] = stats.converged;
}

// Fourth argument: ORB pyramid levels, 0 = recon track's (by the scan's motion: 3 on the rotator);
// 8 = ORB-SLAM2's, the reference for the levels' trade (recon/tracking/README.md).
BENCHMARK(BM_Frontend)
    ->Args({640, 16, 1, 0})
    ->Args({640, 16, 1, 8})
    ->Args({640, 16, 0, 0})
    ->Args({320, 16, 1, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
// Third argument: 0 = SPARSE_SCHUR (default), 1 = SPARSE_NORMAL_CHOLESKY, 2 = DENSE_SCHUR,
// 3 = ITERATIVE_SCHUR (SCHUR_JACOBI; not run here: 31 s at 640/16 against 2.8 s, see
// recon/tracking/README.md "Solver speed").
BENCHMARK(BM_Solve)
    ->Args({640, 16, 0, 0})
    ->Args({640, 16, 0, 1})
    ->Args({640, 16, 2, 0})
    ->Args({320, 32, 0, 0})
    ->Args({320, 16, 0, 0})
    ->Args({320, 16, 1, 0})
    ->Args({320, 8, 0, 0})
    ->Unit(benchmark::kSecond)
    ->Iterations(1);

}  // namespace
}  // namespace panoscan

int main(int argc, char** argv) { return panoscan::bench::run_benchmarks(argc, argv); }
