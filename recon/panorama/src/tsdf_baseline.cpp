// TSDF baseline (Tables 1 and 3) through Open3D's hashed TSDF volume (recon/open3d: loaded on first use).
#include "panoscan/core/timer.h"
#include "panoscan/recon/tsdf_baseline.h"

#include <chrono>
#include <cmath>

#include "panoscan/core/error.h"
#include "panoscan/recon/open3d_calls.h"

namespace panoscan {

void TsdfOptions::check(const std::string& origin) const {
  if (!(voxel_m > 0) || voxel_m > 1) throw make_error(origin, "tsdf.voxel_m", "must be in (0, 1]");
  if (!(truncation_m > voxel_m)) throw make_error(origin, "tsdf.truncation_m", "must exceed the voxel size");
  if (!(max_depth_m > 0)) throw make_error(origin, "tsdf.max_depth_m", "must be > 0");
  if (frame_stride < 1) throw make_error(origin, "tsdf.frame_stride", "must be >= 1");
}

TsdfResult build_tsdf_baseline(const ScanIndex& scan, const RigTrajectory& trajectory, const TsdfOptions& options) {
  options.check();
  check_rig_trajectory(trajectory, scan, "poses");
  using Clock = std::chrono::steady_clock;
  open3d_calls::TsdfVolume volume(options.voxel_m, options.truncation_m);  // loads Open3D before the clock
  TsdfResult result;
  const auto t0 = Clock::now();
  for (std::size_t s = 0; s < scan.frames.size(); ++s) {
    const PinholeIntrinsics& k = scan.rig.sensors[s].intrinsics;
    for (std::size_t f = 0; f < scan.frames[s].size(); f += std::size_t(options.frame_stride)) {
      const Eigen::Matrix4d cam_from_world = trajectory.world_from_cam[s][f].world_from_cam.inverse().matrix();
      volume.integrate(load_frame(scan, int(s), f), options.max_depth_m, k, cam_from_world);
    }
  }
  const auto t1 = Clock::now();
  const open3d_calls::TsdfMesh mesh = volume.extract_mesh();
  const auto t2 = Clock::now();
  result.volume_units = mesh.volume_units;
  const std::size_t unit_voxels = std::size_t(mesh.unit_resolution) * mesh.unit_resolution * mesh.unit_resolution;
  // Open3D's coloured voxel: tsdf + weight (float each) + colour (3 doubles) + grid index (3 ints).
  result.memory_bytes = result.volume_units * unit_voxels * (2 * sizeof(float) + 3 * sizeof(double) + 3 * sizeof(int));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    result.mesh.vertices.push_back(mesh.vertices[i].cast<float>());
    result.vertices.positions.push_back(mesh.vertices[i]);
    if (!mesh.colours.empty()) {
      const Eigen::Vector3d c = mesh.colours[i];
      result.vertices.colours.push_back({std::uint8_t(std::lround(std::clamp(c.x(), 0.0, 1.0) * 255)),
                                         std::uint8_t(std::lround(std::clamp(c.y(), 0.0, 1.0) * 255)),
                                         std::uint8_t(std::lround(std::clamp(c.z(), 0.0, 1.0) * 255))});
    }
  }
  for (const Eigen::Vector3i& t : mesh.triangles) result.mesh.triangles.push_back(t);
  result.integrate_seconds = seconds_between(t0, t1);
  result.extract_seconds = seconds_between(t1, t2);
  return result;
}

}  // namespace panoscan
