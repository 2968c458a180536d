// Trajectory errors as the TUM RGB-D benchmark defines them (Sturm et al., IROS 2012), for each
// tracked camera against its ground truth (both world_from_cam, TUM files).
//
// Association: each estimated pose is matched to the ground-truth pose with the nearest
// timestamp if they differ by at most max_time_difference_s (default: equal up to the 6-decimal
// text format); each pose is used at most once.
// ATE: positions aligned by the closed-form least-squares rigid transform (Horn 1987 /
// Umeyama 1991, without scale): minimise sum |p_gt_i - (R p_est_i + t)|^2; the ATE is the RMSE of
// the remaining position differences (and mean, median, max).
// RPE: for each matched pose i, j is the matched pose whose timestamp is closest to t_i + delta
// (pairs whose target time lies beyond the last pose, or with j == i, are skipped);
// E_ij = (gt_i^-1 gt_j)^-1 (est_i^-1 est_j); translational RPE = |trans(E_ij)|, rotational RPE =
// angle(E_ij). No alignment is needed (it cancels).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/eval/error_stats.h"

namespace panoscan::eval {

struct TrajectoryMetricsOptions {
  double max_time_difference_s = 1e-4;
  double rpe_delta_s = 1.0;
  bool align = true;  // false: ATE in the trajectories' own frames (both already in the scene frame)

  void check(const std::string& origin = "<trajectory evaluation options>") const;
};

// Index pairs (gt index, est index) in increasing time.
std::vector<std::pair<std::size_t, std::size_t>> associate_by_timestamp(const std::vector<StampedPose>& gt,
                                                                        const std::vector<StampedPose>& est,
                                                                        double max_time_difference_s);

struct TrajectoryMetrics {
  std::size_t gt_poses = 0, est_poses = 0, matched_poses = 0;
  Rigid3d gt_from_est = Rigid3d::Identity();  // the ATE alignment (identity when align is off)
  ErrorStats ate_m;                           // translational, after alignment
  ErrorStats ate_rotation_deg;                // rotation of gt_i^-1 * (gt_from_est * est_i), beyond TUM
  double rpe_delta_s = 0.0;
  ErrorStats rpe_translation_m;
  ErrorStats rpe_rotation_deg;
  // For plots: the matched timestamps, ground-truth positions and aligned estimated positions.
  std::vector<double> timestamps;
  std::vector<Eigen::Vector3d> gt_positions, est_positions_aligned;
};

// Throws Error naming both origins when nothing associates, fewer than 3 poses match, or no RPE
// pair exists (trajectory shorter than delta).
TrajectoryMetrics evaluate_trajectory(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                      const TrajectoryMetricsOptions& options, const std::string& gt_origin,
                                      const std::string& est_origin);

}  // namespace panoscan::eval
