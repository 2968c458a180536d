// ATE and RPE as in the TUM RGB-D benchmark tools (definitions in trajectory_metrics.h).

#include "panoscan/eval/trajectory_metrics.h"

#include <algorithm>
#include <cmath>

#include "panoscan/core/error.h"

namespace panoscan::eval {

namespace {

void check_trajectory(const std::vector<StampedPose>& poses, const std::string& origin) {
  if (poses.empty()) throw make_error(origin, "", "the trajectory has no poses");
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!std::isfinite(poses[i].timestamp) || !poses[i].world_from_cam.matrix().allFinite())
      throw make_error(origin, "pose " + std::to_string(i), "non-finite timestamp or pose");
    if (i > 0 && !(poses[i].timestamp > poses[i - 1].timestamp))
      throw make_error(origin, "pose " + std::to_string(i), "timestamps must strictly increase");
  }
}

double median_spacing(const std::vector<double>& times) {
  std::vector<double> gaps;
  for (std::size_t i = 1; i < times.size(); ++i) gaps.push_back(times[i] - times[i - 1]);
  if (gaps.empty()) return 0.0;
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

}  // namespace

void TrajectoryMetricsOptions::check(const std::string& origin) const {
  if (!(max_time_difference_s >= 0) || !std::isfinite(max_time_difference_s))
    throw make_error(origin, "max_time_difference_s", "must be >= 0");
  if (!(rpe_delta_s > 0) || !std::isfinite(rpe_delta_s)) throw make_error(origin, "rpe_delta_s", "must be positive");
}

std::vector<std::pair<std::size_t, std::size_t>> associate_by_timestamp(const std::vector<StampedPose>& gt,
                                                                        const std::vector<StampedPose>& est,
                                                                        double max_time_difference_s) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  std::vector<bool> gt_used(gt.size(), false);
  for (std::size_t e = 0; e < est.size(); ++e) {
    const double t = est[e].timestamp;
    const auto after = std::lower_bound(gt.begin(), gt.end(), t,
                                        [](const StampedPose& pose, double time) { return pose.timestamp < time; });
    std::size_t best = gt.size();
    double best_gap = max_time_difference_s;
    for (auto candidate : {after - (after != gt.begin() ? 1 : 0), after}) {
      if (candidate == gt.end()) continue;
      const std::size_t g = static_cast<std::size_t>(candidate - gt.begin());
      const double gap = std::abs(gt[g].timestamp - t);
      if (gap <= best_gap && !gt_used[g] && (best == gt.size() || gap < best_gap)) {
        best = g;
        best_gap = gap;
      }
    }
    if (best != gt.size()) {
      gt_used[best] = true;
      pairs.emplace_back(best, e);
    }
  }
  return pairs;
}

namespace {

// The ATE alignment (Umeyama without scale: core's fit_rigid_transform). Positions on one line
// (or one point) leave a rotation free: then only the centroids are matched, a valid minimiser.
Rigid3d align_positions(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target) {
  Rigid3d target_from_source = Rigid3d::Identity();
  if (fit_rigid_transform(source, target, target_from_source)) return target_from_source;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < source.size(); ++i) offset += target[i] - source[i];
  target_from_source.translation() = offset / double(std::max<std::size_t>(1, source.size()));
  return target_from_source;
}

}  // namespace

TrajectoryMetrics evaluate_trajectory(const std::vector<StampedPose>& gt, const std::vector<StampedPose>& est,
                                      const TrajectoryMetricsOptions& options, const std::string& gt_origin,
                                      const std::string& est_origin) {
  options.check();
  check_trajectory(gt, gt_origin);
  check_trajectory(est, est_origin);
  TrajectoryMetrics metrics;
  metrics.gt_poses = gt.size();
  metrics.est_poses = est.size();

  const auto pairs = associate_by_timestamp(gt, est, options.max_time_difference_s);
  metrics.matched_poses = pairs.size();
  const std::string both = gt_origin + " vs " + est_origin;
  if (pairs.empty())
    throw make_error(both, "timestamps",
                     "no common timestamps (within " + std::to_string(options.max_time_difference_s) +
                         " s): ground truth spans " + std::to_string(gt.front().timestamp) + " .. " +
                         std::to_string(gt.back().timestamp) + " s, the estimate " +
                         std::to_string(est.front().timestamp) + " .. " + std::to_string(est.back().timestamp) + " s");
  if (pairs.size() < 3)
    throw make_error(both, "timestamps",
                     "only " + std::to_string(pairs.size()) + " poses match; the alignment needs at least 3");

  std::vector<Rigid3d> gt_matched, est_matched;
  for (const auto& [g, e] : pairs) {
    gt_matched.push_back(gt[g].world_from_cam);
    est_matched.push_back(est[e].world_from_cam);
    metrics.timestamps.push_back(est[e].timestamp);
    metrics.gt_positions.push_back(gt[g].world_from_cam.translation());
  }

  // ATE: align the estimated positions onto the ground truth, then the residual positions.
  std::vector<Eigen::Vector3d> est_positions;
  for (const Rigid3d& pose : est_matched) est_positions.push_back(pose.translation());
  metrics.gt_from_est = options.align ? align_positions(est_positions, metrics.gt_positions) : Rigid3d::Identity();
  std::vector<double> ate, ate_rotation;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Rigid3d est_aligned = metrics.gt_from_est * est_matched[k];
    metrics.est_positions_aligned.push_back(est_aligned.translation());
    ate.push_back((est_aligned.translation() - gt_matched[k].translation()).norm());
    ate_rotation.push_back(rad2deg(rotation_angle(gt_matched[k].linear().transpose() * est_aligned.linear())));
  }
  metrics.ate_m = summarize_errors(ate);
  metrics.ate_rotation_deg = summarize_errors(ate_rotation);

  // RPE over a fixed time delta.
  metrics.rpe_delta_s = options.rpe_delta_s;
  const std::vector<double>& times = metrics.timestamps;
  const double end_slack = 0.5 * median_spacing(times);
  std::vector<double> rpe_translation, rpe_rotation;
  for (std::size_t i = 0; i < times.size(); ++i) {
    const double target_time = times[i] + options.rpe_delta_s;
    if (target_time > times.back() + end_slack) break;  // beyond the last pose
    const auto after = std::lower_bound(times.begin(), times.end(), target_time);
    std::size_t j = static_cast<std::size_t>(after - times.begin());
    if (j == times.size() || (j > 0 && target_time - times[j - 1] < times[j] - target_time)) j = j - 1;
    if (j <= i) continue;
    const Rigid3d gt_motion = gt_matched[i].inverse() * gt_matched[j];
    const Rigid3d est_motion = est_matched[i].inverse() * est_matched[j];
    const Rigid3d error = gt_motion.inverse() * est_motion;
    rpe_translation.push_back(error.translation().norm());
    rpe_rotation.push_back(rad2deg(rotation_angle(error.linear())));
  }
  if (rpe_translation.empty())
    throw make_error(both, "rpe_delta_s",
                     "no pose pair is " + std::to_string(options.rpe_delta_s) + " s apart (the matched poses span " +
                         std::to_string(times.back() - times.front()) + " s); use a smaller delta");
  metrics.rpe_translation_m = summarize_errors(rpe_translation);
  metrics.rpe_rotation_deg = summarize_errors(rpe_rotation);
  return metrics;
}

}  // namespace panoscan::eval
