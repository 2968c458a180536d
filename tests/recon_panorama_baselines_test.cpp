// The TSDF and surfel baselines (Tables 1 and 3). Table 3 itself: `panoscan tables table3`
// (benchmarks/tables/src/table3.cpp). The 5 mm TSDF of a whole room takes ~8 GB and many minutes
// with Open3D (its coloured voxels hold doubles).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "panoscan/core/error.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/eval/mesh_distance.h"
#include "panoscan/recon/panorama.h"
#include "panoscan/recon/surfel_baseline.h"
#include "panoscan/recon/tsdf_baseline.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

using namespace panoscan;

namespace {

// Open3D's loops use OpenMP, whose idle threads spin by default: on a shared 2-core machine that
// made integration 40x slower. Passive waiting is set before the OpenMP runtime starts.
[[maybe_unused]] const bool kPassiveOpenMp = [] { return ::setenv("OMP_WAIT_POLICY", "PASSIVE", 0) == 0; }();

double rmse_against_mesh(const eval::MeshDistance& mesh, const std::vector<Eigen::Vector3d>& points) {
  const std::vector<double> d = mesh.distances(points);
  double s = 0;
  for (double x : d) s += x * x;
  return std::sqrt(s / double(d.size()));
}

// Office SO-1 at 160x120, every 30th frame, Handa noise: small enough for the baselines' tests.
ScanIndex simulate_small_office_scan(const Scene& scene, const std::filesystem::path& dir) {
  SimOptions options;
  options.rig.width = 160;
  options.rig.height = 120;
  options.output.every = 30;
  options.seed = 7;
  Simulator(scene, 0, options).write_scan(dir, false);
  return read_scan_index(dir);
}

}  // namespace

TEST(TsdfBaseline, OfficeMeshIsCloseToTheTruth) {
  testutil::TempDir tmp("tsdf");
  const Scene scene = scenes::make_builtin_scene("office");
  const ScanIndex scan = simulate_small_office_scan(scene, tmp / "scan");
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(tmp / "scan");
  TsdfOptions tsdf;
  tsdf.voxel_m = 0.01;  // the low-resolution scan does not support 5 mm voxels
  tsdf.frame_stride = 2;
  const TsdfResult result = build_tsdf_baseline(scan, truth, tsdf);
  ASSERT_GT(result.mesh.triangles.size(), 1000u);
  const eval::MeshDistance mesh(scene.mesh);
  const double rmse = rmse_against_mesh(mesh, result.vertices.positions);
  std::vector<double> d = mesh.distances(result.vertices.positions);
  std::nth_element(d.begin(), d.begin() + std::ptrdiff_t(d.size() / 2), d.end());
  EXPECT_LT(d[d.size() / 2], 0.01);
  std::cout << "TSDF: median " << d[d.size() / 2] * 1e3 << " mm, " << result.vertices.size() << " vertices, rmse "
            << rmse * 1e3 << " mm, " << result.volume_units << " blocks, ~" << result.memory_bytes / 1048576.0
            << " MiB, integrate " << result.integrate_seconds << " s\n";
  EXPECT_LT(rmse, 0.05);  // 160x120 depth with Handa noise: blobby, but no gross error
  EXPECT_GT(result.memory_bytes, 0u);

  RigTrajectory short_poses = truth;
  short_poses.world_from_cam[0].pop_back();
  EXPECT_THROW(build_tsdf_baseline(scan, short_poses, tsdf), Error);
  tsdf.truncation_m = 0.001;
  EXPECT_THROW(build_tsdf_baseline(scan, truth, tsdf), Error);
}

std::vector<Eigen::Vector3d> panorama_points(const ImageF32& depth, const Rigid3d& world_from_pano,
                                             const Equirectangular& pano) {
  std::vector<Eigen::Vector3d> points;
  for (int v = 0; v < depth.height; ++v)
    for (int u = 0; u < depth.width; ++u)
      if (depth.at(u, v) > 0) points.push_back(world_from_pano * (double(depth.at(u, v)) * pano.direction(u, v)));
  return points;
}

TEST(SurfelBaseline, OfficeSurfelsAndRaycastAreCloseToTheTruth) {
  testutil::TempDir tmp("surfels");
  const Scene scene = scenes::make_builtin_scene("office");
  const ScanIndex scan = simulate_small_office_scan(scene, tmp / "scan");
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(tmp / "scan");
  const eval::MeshDistance mesh(scene.mesh);
  SurfelOptions surfel_options;
  surfel_options.direction_bins_height = 256;
  const SurfelResult four = build_surfel_baseline(scan, truth, surfel_options);
  surfel_options.max_depth_m = 3.0;
  const SurfelResult three = build_surfel_baseline(scan, truth, surfel_options);
  ASSERT_GT(four.surfels.size(), 1000u);
  EXPECT_LT(three.surfels.size(), four.surfels.size());
  const double rmse4 = rmse_against_mesh(mesh, four.surfels.positions);
  const double rmse3 = rmse_against_mesh(mesh, three.surfels.positions);
  Equirectangular pano;
  pano.height = 128;
  const ImageF32 rc = raycast_surfels(four, truth.world_from_axis, pano);
  const double rmse_rc = rmse_against_mesh(mesh, panorama_points(rc, truth.world_from_axis, pano));
  std::cout << "surfels: 4 m " << four.surfels.size() << " rmse " << rmse4 * 1e3 << " mm; 3 m " << three.surfels.size()
            << " rmse " << rmse3 * 1e3 << " mm; ray-cast rmse " << rmse_rc * 1e3 << " mm; " << four.seconds << " s\n";
  EXPECT_LT(rmse4, 0.03);
  EXPECT_LT(rmse3, rmse4);
  EXPECT_LT(rmse_rc, 0.05);
}
