// The tracking metrics shared by Table 2 and Fig. 8: stitched ground-truth depth, the pose alignment
// that ties an estimate to the scene frame, and the ATE (see tracking_eval.h).
#include "tracking_eval.h"

#include <cmath>

#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/eval/error_stats.h"
#include "panoscan/eval/trajectory_metrics.h"

namespace panoscan::tables {

namespace tracking_eval {

std::vector<std::vector<std::vector<Eigen::Vector3d>>> mesh_points_in_camera(const ScanIndex& scan,
                                                                             const RigTrajectory& truth,
                                                                             const eval::MeshDistance& mesh,
                                                                             const std::vector<int>& sensors,
                                                                             double stride_at_320_px) {
  constexpr double kMaxSnapM = 0.05;
  std::vector<std::vector<std::vector<Eigen::Vector3d>>> out(scan.frames.size());
  for (int s : sensors) {
    out[s].resize(scan.frames[s].size());
    const PinholeIntrinsics& intrinsics = scan.rig.sensors[s].intrinsics;
    const int stride = std::max(1, int(std::lround(stride_at_320_px * intrinsics.width / 320.0)));
    tbb::parallel_for(std::size_t(0), scan.frames[s].size(), [&](std::size_t f) {
      const RgbdFrame frame = load_frame(scan, s, f);
      const Rigid3d& world_from_cam = truth.world_from_cam[s][f].world_from_cam;
      const Rigid3d cam_from_world = world_from_cam.inverse();
      for (int v = stride / 2; v < frame.depth.height; v += stride)
        for (int u = stride / 2; u < frame.depth.width; u += stride) {
          const float z = frame.depth.data[std::size_t(v) * frame.depth.width + u];
          if (!(z > 0)) continue;
          const auto closest = mesh.closest(world_from_cam * intrinsics.backproject(u, v, z));
          if (closest.distance > kMaxSnapM) continue;
          out[s][f].push_back(cam_from_world * closest.point);
        }
    });
  }
  return out;
}

Rigid3d pose_alignment(const RigTrajectory& truth, const RigTrajectory& estimate, const std::vector<int>& sensors) {
  std::vector<Rigid3d> truth_poses, estimate_poses;
  for (int s : sensors)
    for (std::size_t f = 0; f < estimate.world_from_cam[s].size(); ++f) {
      truth_poses.push_back(truth.world_from_cam[s][f].world_from_cam);
      estimate_poses.push_back(estimate.world_from_cam[s][f].world_from_cam);
    }
  return fit_rigid_transform_of_poses(estimate_poses, truth_poses);
}

double stitched_rmse_m(const std::vector<std::vector<std::vector<Eigen::Vector3d>>>& points_in_camera,
                       const RigTrajectory& estimate, const Rigid3d& truth_from_estimate,
                       const eval::MeshDistance& mesh, const std::vector<int>& sensors) {
  std::vector<Eigen::Vector3d> placed;
  for (int s : sensors)
    for (std::size_t f = 0; f < points_in_camera[s].size(); ++f) {
      const Rigid3d pose = truth_from_estimate * estimate.world_from_cam[s][f].world_from_cam;
      for (const Eigen::Vector3d& p : points_in_camera[s][f]) placed.push_back(pose * p);
    }
  if (placed.empty()) return std::nan("");
  return eval::summarize_errors(mesh.distances(placed, "stitched ground-truth depth")).rmse;
}

double ate_m(const RigTrajectory& truth, const RigTrajectory& estimate, int sensor) {
  const auto& poses = estimate.world_from_cam[sensor];
  eval::TrajectoryMetricsOptions metrics;  // only the ATE is used; an RPE delta every sparsity can meet
  if (poses.size() >= 2) metrics.rpe_delta_s = 0.5 * (poses.back().timestamp - poses.front().timestamp);
  return eval::evaluate_trajectory(truth.world_from_cam[sensor], poses, metrics, "ground truth", "tracked").ate_m.rmse;
}

}  // namespace tracking_eval

}  // namespace panoscan::tables
