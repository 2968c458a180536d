// verify_tracking (tracking.h): the self-check of a tracked trajectory. A wrong trajectory written
// as a result is the worst outcome a testbed can have; each check compares the solution with a
// property every rotator scan has, or with what the front end measured on its own (the only checks
// of a handheld recording).
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/tracking.h"

namespace panoscan {

std::string TrackingVerdict::first_failure() const {
  for (const TrackingCheck& c : checks)
    if (!c.passed) return c.name + ": " + c.detail;
  return "";
}

void require_reliable_tracking(const TrackingResult& result, const TrackingOptions& options,
                               const std::string& scan_name) {
  if (result.verdict.reliable) return;
  const std::string why = "not trustworthy: " + result.verdict.first_failure();
  if (!options.allow_unreliable) throw make_refusal(scan_name, "tracking", why);
  log_warn(scan_name + ": tracking " + why + " (kept: track.allow_unreliable)");
}

namespace {

struct PairCheck {
  int pairs = 0, consistent = 0;
  int worst_kept = 0, worst_inliers = 0;  // the pair whose inliers the trajectory explains least
  std::vector<int> pairs_of, consistent_of;  // per sensor: the pairs it is in (a cross-camera pair counts for both)
};

// Tracked against the front end's verified pairs of one kind: a pair agrees when the tracked
// relative pose keeps at least min_pair_inlier_share of the pair's RANSAC inliers within their
// thresholds, i.e. when the trajectory explains what the pair measured. Comparing poses instead
// (tracked against the pair's a_from_b, within fixed tolerances) refused right trajectories: in a
// plain room a pair's RANSAC pose from 12-36 inliers was off the truth by up to 8.9 deg / 350 mm
// while its inliers fit the truth too (recon/tracking/README.md, "The self-check").
PairCheck check_pairs(const TrackingResult& result, const FrontendResult& frontend,
                      const std::vector<std::vector<int>>& observations, bool loop, const TrackingVerifyOptions& v) {
  PairCheck out;
  out.pairs_of.assign(observations.size(), 0);
  out.consistent_of.assign(observations.size(), 0);
  double worst_share = 2.0;
  for (const FramePairMatch& p : frontend.pairs) {
    if ((p.kind == FramePairMatch::Kind::kLoop) != loop) continue;
    if (observations[p.sensor_a].empty() || observations[p.sensor_b].empty()) continue;  // camera outside the graph
    // The front end keeps every accepted pair's correspondences; a pair without them cannot be checked.
    if (p.points_a.empty() || p.points_b.size() != p.points_a.size() || p.thresholds.size() != p.points_a.size())
      throw make_error(
          "verify_tracking", "frontend.pairs",
          fmt::format("the pair of frame {} of sensor {} and frame {} of sensor {} has no inliers to check", p.frame_a,
                      p.sensor_a, p.frame_b, p.sensor_b));
    const Rigid3d& a = result.trajectory.world_from_cam[p.sensor_a][p.frame_a].world_from_cam;
    const Rigid3d& b = result.trajectory.world_from_cam[p.sensor_b][p.frame_b].world_from_cam;
    const Rigid3d tracked = a.inverse() * b;
    int kept = 0;
    for (std::size_t k = 0; k < p.points_a.size(); ++k)
      kept += (tracked * p.points_b[k] - p.points_a[k]).norm() <= p.thresholds[k];
    const int inliers = int(p.points_a.size());
    const double share = double(kept) / inliers;
    const bool consistent = share >= v.min_pair_inlier_share;
    ++out.pairs;
    out.consistent += consistent;
    for (const int sensor : {p.sensor_a, p.sensor_b}) {
      ++out.pairs_of[std::size_t(sensor)];
      out.consistent_of[std::size_t(sensor)] += consistent;
      if (p.sensor_b == p.sensor_a) break;
    }
    if (share < worst_share) {
      worst_share = share;
      out.worst_kept = kept;
      out.worst_inliers = inliers;
    }
  }
  return out;
}

}  // namespace

TrackingVerdict verify_tracking(const TrackingResult& result, const ScanIndex& scan, const FrontendResult& frontend,
                                const std::vector<std::vector<int>>& observations,
                                const std::vector<double>& residual_norms, const TrackingOptions& options) {
  const TrackingVerifyOptions& v = options.verify;
  const int sensors = int(scan.rig.sensors.size());
  const int ref = scan.rig.reference_sensor;
  TrackingVerdict verdict;
  verdict.frames.resize(sensors);
  for (int s = 0; s < sensors; ++s) verdict.frames[s].resize(scan.frames[s].size());
  if (int(observations.size()) != sensors || int(result.trajectory.world_from_cam.size()) != sensors)
    throw make_error(scan.root.string(), "tracking", "verification input does not match the scan's sensors");
  auto add = [&](std::string name, bool passed, double value, double limit, std::string detail) {
    verdict.checks.push_back({std::move(name), passed, value, limit, std::move(detail)});
    verdict.reliable = verdict.reliable && passed;
  };

  // finite
  bool finite = result.trajectory.world_from_axis.matrix().allFinite();
  for (const auto& poses : result.trajectory.world_from_cam)
    for (const StampedPose& p : poses) finite = finite && p.world_from_cam.matrix().allFinite();
  add("finite", finite, finite ? 0 : 1, 0, finite ? "every pose is finite" : "the solution has non-finite poses");
  if (!finite) {
    verdict.checked = true;
    return verdict;
  }

  // A handheld recording (rig.json "motion": handheld) has no turn, no azimuth and no axis: the
  // checks of the rotator's motion are left out, and the frames check measures its gaps in seconds.
  const bool rotator = scan.rig.motion == RigMotion::kRotator;

  // turn and monotone: the reference camera's azimuth.
  const std::vector<double>& azimuth = result.azimuth_unwrapped_rad[ref];
  const std::vector<FrameEntry>& ref_frames = scan.frames[ref];
  const double turn_deg = azimuth.size() > 1 ? rad2deg(azimuth.back() - azimuth.front()) : 0.0;
  const double direction = turn_deg < 0 ? -1.0 : 1.0;
  const double duration_s = ref_frames.size() > 1 ? ref_frames.back().timestamp - ref_frames.front().timestamp : 0.0;
  const double rate_deg_s = duration_s > 0 ? std::abs(turn_deg) / duration_s : 0.0;

  // frames: instants where some camera in the graph has min_frame_observations observations or (on
  // the rotator) is in a depth-odometry pair that measures the turn to max_depth_yaw_std_deg; the
  // longest stretch between two of them: on the rotator as a turn (time x mean turn rate, so that a
  // wrong azimuth cannot hide it), handheld in seconds. Depth pairs count on the rotator only: there
  // the turn is the one direction the check is about; a handheld pose has six.
  // A pair (first frame k) that measures the turn and that the solution agrees with.
  auto pair_supports = [&](int s, std::size_t k) {
    const std::size_t sensor = std::size_t(s);
    const bool measures = sensor < result.depth_yaw_std_deg.size() && k < result.depth_yaw_std_deg[sensor].size() &&
                          result.depth_yaw_std_deg[sensor][k] <= v.max_depth_yaw_std_deg;
    // A result without the residuals (built by hand) is taken as agreeing.
    const bool agrees = sensor >= result.depth_pair_residual.size() || k >= result.depth_pair_residual[sensor].size() ||
                        result.depth_pair_residual[sensor][k] <= kDepthOdometryHuber;
    return measures && agrees;
  };
  auto depth_yaw_std = [&](int s, std::size_t f) {
    double best = std::numeric_limits<double>::infinity();
    if (std::size_t(s) < result.depth_yaw_std_deg.size()) {
      const std::vector<double>& pairs = result.depth_yaw_std_deg[std::size_t(s)];
      if (f < pairs.size()) best = std::min(best, pairs[f]);                    // the pair (f, f + 1)
      if (f >= 1 && f - 1 < pairs.size()) best = std::min(best, pairs[f - 1]);  // the pair (f - 1, f)
    }
    return best;
  };
  auto depth_supported = [&](int s, std::size_t f) {
    return rotator && v.max_depth_yaw_std_deg > 0 && !observations[s].empty() &&
           (pair_supports(s, f) || (f >= 1 && pair_supports(s, f - 1)));
  };
  std::vector<double> supported_times;
  for (int s = 0; s < sensors; ++s)
    for (std::size_t f = 0; f < observations[s].size(); ++f)
      if (observations[s][f] >= v.min_frame_observations || depth_supported(s, f))
        supported_times.push_back(scan.frames[s][f].timestamp);
  std::sort(supported_times.begin(), supported_times.end());
  double longest_gap_s = std::numeric_limits<double>::infinity();
  if (!supported_times.empty() && !ref_frames.empty()) {
    longest_gap_s = std::max(supported_times.front() - ref_frames.front().timestamp,
                             ref_frames.back().timestamp - supported_times.back());
    for (std::size_t k = 1; k < supported_times.size(); ++k)
      longest_gap_s = std::max(longest_gap_s, supported_times[k] - supported_times[k - 1]);
  }
  const double gap_limit = rotator ? v.max_unsupported_turn_deg : v.max_unsupported_s;
  auto gap_measure = [&](double seconds) { return rotator ? rate_deg_s * seconds : seconds; };
  for (int s = 0; s < sensors; ++s)
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      FrameSupport& support = verdict.frames[s][f];
      support.observations = f < observations[s].size() ? observations[s][f] : 0;
      support.depth_yaw_std_deg = depth_yaw_std(s, f);
      support.depth_supported = f < observations[s].size() && depth_supported(s, f);
      if (std::size_t(s) < result.depth_pair_residual.size() && f < result.depth_pair_residual[std::size_t(s)].size())
        support.depth_residual = result.depth_pair_residual[std::size_t(s)][f];
      if (std::size_t(s) < result.model_departure_mm.size() && f < result.model_departure_mm[std::size_t(s)].size()) {
        support.model_departure_mm = result.model_departure_mm[std::size_t(s)][f];
        support.model_departure_deg = result.model_departure_deg[std::size_t(s)][f];
      }
      const double t = scan.frames[s][f].timestamp;
      double nearest_s = std::numeric_limits<double>::infinity();
      const auto it = std::lower_bound(supported_times.begin(), supported_times.end(), t);
      if (it != supported_times.end()) nearest_s = std::min(nearest_s, *it - t);
      if (it != supported_times.begin()) nearest_s = std::min(nearest_s, t - *(it - 1));
      support.gap_s = std::isfinite(nearest_s) ? nearest_s : duration_s;
      support.gap_deg = rotator ? (std::isfinite(nearest_s) ? rate_deg_s * nearest_s : 360.0) : 0.0;
      const double gap = std::isfinite(nearest_s) ? gap_measure(nearest_s) : gap_limit;
      support.confidence = std::max(std::min(1.0, double(support.observations) / v.min_frame_observations),
                                    support.depth_supported ? 1.0 : 0.0) *
                           std::max(0.0, 1.0 - gap / gap_limit);
    }
  const double longest_gap = std::isfinite(longest_gap_s) ? gap_measure(longest_gap_s) : longest_gap_s;
  std::string frames_detail;
  if (!std::isfinite(longest_gap))
    frames_detail = fmt::format("no frame has {} or more observations", v.min_frame_observations);
  else if (rotator && v.max_depth_yaw_std_deg <= 0)
    frames_detail = fmt::format(
        "the longest stretch without a frame of {} or more observations spans {:.1f} deg of the turn "
        "(at most {:.0f}): there only Eq. 2-3 carry the azimuth",
        v.min_frame_observations, longest_gap, v.max_unsupported_turn_deg);
  else if (rotator)
    frames_detail = fmt::format(
        "the longest stretch without a frame of {} or more observations or a depth-odometry pair that measures "
        "the turn to {:.2f} deg and agrees with the solution spans {:.1f} deg of the turn (at most {:.0f}): there "
        "only Eq. 2-3 carry the azimuth",
        v.min_frame_observations, v.max_depth_yaw_std_deg, longest_gap, v.max_unsupported_turn_deg);
  else
    frames_detail = fmt::format(
        "the longest stretch without a frame of {} or more observations lasts {:.2f} s (at most {:.2f}): there "
        "the poses are extrapolated",
        v.min_frame_observations, longest_gap, v.max_unsupported_s);
  add("frames", longest_gap <= gap_limit, longest_gap, gap_limit, frames_detail);
  if (rotator) {
    add("turn", std::abs(turn_deg) >= v.min_turn_deg && std::abs(turn_deg) <= v.max_turn_deg, std::abs(turn_deg),
        std::abs(turn_deg) < v.min_turn_deg ? v.min_turn_deg : v.max_turn_deg,
        fmt::format("the reference camera turns {:.1f} deg; a panoramic scan is one revolution ({:.0f} to {:.0f} deg)",
                    std::abs(turn_deg), v.min_turn_deg, v.max_turn_deg));
    double worst_backward_deg = 0.0;
    for (std::size_t k = 1; k < azimuth.size(); ++k)
      worst_backward_deg = std::max(worst_backward_deg, -direction * rad2deg(azimuth[k] - azimuth[k - 1]));
    add("monotone", worst_backward_deg <= v.max_backward_step_deg, worst_backward_deg, v.max_backward_step_deg,
        fmt::format(
            "the azimuth steps back by up to {:.2f} deg between frames (at most {:.1f}); the rotator turns one way",
            worst_backward_deg, v.max_backward_step_deg));
  }

  // model: each frame's departure from the rotator model (Eq. 2), whitened by Eq. 2's standard deviations.
  if (rotator) {
    const double sigma_mm = 1e3 * options.reg_translation_std_m, sigma_deg = options.reg_rotation_std_deg;
    double worst = 0.0, worst_mm = 0.0, worst_deg = 0.0;
    std::string worst_frame;
    bool modelled = false;
    for (int s = 0; s < sensors && std::size_t(s) < result.model_departure_mm.size(); ++s)
      for (std::size_t f = 0; f < result.model_departure_mm[std::size_t(s)].size() &&
                              f < result.model_departure_deg[std::size_t(s)].size();
           ++f) {
        modelled = true;
        const double mm = result.model_departure_mm[std::size_t(s)][f],
                     deg = result.model_departure_deg[std::size_t(s)][f];
        const double sigma = std::hypot(mm / sigma_mm, deg / sigma_deg);
        if (!(sigma <= worst) || worst_frame.empty()) {  // a NaN is the worst
          worst = std::isnan(sigma) ? std::numeric_limits<double>::infinity() : sigma;
          worst_mm = mm;
          worst_deg = deg;
          worst_frame = fmt::format("{} frame {}", scan.rig.sensors[std::size_t(s)].name, f);
        }
      }
    if (modelled)
      add("model", worst <= v.max_model_departure_sigma, worst, v.max_model_departure_sigma,
          fmt::format("{} departs {:.1f} mm / {:.2f} deg from the rotator model, {:.1f} times Eq. 2's {:.0f} mm / "
                      "{:.1f} deg (at most {:.1f}): the rig's wobble cannot put a camera there",
                      worst_frame, worst_mm, worst_deg, worst, sigma_mm, sigma_deg, v.max_model_departure_sigma));
  }

  // pairs and loop: the front end's verified frame pairs.
  for (const bool loop : {false, true}) {
    const PairCheck p = check_pairs(result, frontend, observations, loop, v);
    const double pooled = p.pairs > 0 ? double(p.consistent) / p.pairs : 1.0;
    const char* what = loop ? "loop-closure pairs" : "verified frame pairs";
    const double min_share = loop ? v.min_consistent_loop_share : v.min_consistent_pair_share;
    // The same-camera pairs are also held per camera: pooled, one camera's wrong trajectory hides
    // among the others' pairs (every other frame of one camera turned 3 deg: 228 of 258 agreed). A
    // camera counts once one disagreeing pair of its own cannot sink it below min_share alone:
    // 1 / (1 - min_share) pairs (5 at 0.8). Loop pairs stay pooled: a repetitive room's false loop
    // matches can crowd one camera's few.
    double share = pooled;
    std::string worst_camera;
    if (!loop) {
      const double needed = min_share < 1.0 ? std::ceil(1.0 / (1.0 - min_share) - 1e-9) : 1.0;
      for (std::size_t s = 0; s < p.pairs_of.size(); ++s) {
        if (p.pairs_of[s] < needed) continue;
        const double camera_share = double(p.consistent_of[s]) / p.pairs_of[s];
        if (camera_share < share) {
          share = camera_share;
          worst_camera =
              fmt::format("; {} alone: {} of {}", scan.rig.sensors[s].name, p.consistent_of[s], p.pairs_of[s]);
        }
      }
    }
    add(loop ? "loop" : "pairs", share >= min_share, share, min_share,
        p.pairs == 0 ? fmt::format("no {} to compare with", what)
                     : fmt::format("{} of {} {} agree with the tracked poses (the poses keep at least {:.0f}% of the "
                                   "pair's RANSAC inliers; the worst keeps {} of {}){}",
                                   p.consistent, p.pairs, what, 100.0 * v.min_pair_inlier_share, p.worst_kept,
                                   p.worst_inliers, worst_camera));
  }

  // residuals
  const double outlier_limit = 3.0 * options.huber_delta;
  const std::size_t outliers =
      std::count_if(residual_norms.begin(), residual_norms.end(), [&](double r) { return r > outlier_limit; });
  const double outlier_share = residual_norms.empty() ? 0.0 : double(outliers) / residual_norms.size();
  add("residuals", outlier_share <= v.max_outlier_share, outlier_share, v.max_outlier_share,
      fmt::format("{} of {} observations have a whitened residual above {:.1f} (share {:.3f}, at most {:.2f})",
                  outliers, residual_norms.size(), outlier_limit, outlier_share, v.max_outlier_share));

  // extrinsics: only where the graph estimates them.
  double worst_rotation_deg = 0, worst_translation_m = 0;
  std::string worst_camera;
  for (int s = 0; s < sensors; ++s) {
    if (s == ref) continue;
    const Rigid3d& calibrated = scan.rig.sensors[s].ref_from_cam;
    const Rigid3d& estimated = result.trajectory.ref_from_cam[s];
    const double rotation_deg = rad2deg(rotation_angle(calibrated.linear().transpose() * estimated.linear()));
    const double translation_m = (calibrated.translation() - estimated.translation()).norm();
    if (rotation_deg / v.max_extrinsics_change_deg + translation_m / v.max_extrinsics_change_m >
        worst_rotation_deg / v.max_extrinsics_change_deg + worst_translation_m / v.max_extrinsics_change_m) {
      worst_rotation_deg = rotation_deg;
      worst_translation_m = translation_m;
      worst_camera = scan.rig.sensors[s].name;
    }
  }
  add("extrinsics",
      worst_rotation_deg <= v.max_extrinsics_change_deg && worst_translation_m <= v.max_extrinsics_change_m,
      worst_rotation_deg, v.max_extrinsics_change_deg,
      worst_camera.empty()
          ? std::string("the extrinsics stay at the calibration")
          : fmt::format(
                "{}'s extrinsics moved {:.2f} deg / {:.1f} mm from rig.json's calibration (at most {:.1f} deg / "
                "{:.0f} mm): the calibration is wrong or the tracking failed",
                worst_camera, worst_rotation_deg, worst_translation_m * 1e3, v.max_extrinsics_change_deg,
                v.max_extrinsics_change_m * 1e3));

  // axis: against the reference camera's up (-y) at its first frame; the axis' sign is arbitrary.
  if (rotator) {
    const Eigen::Vector3d axis_in_camera =
        result.trajectory.world_from_cam[ref].front().world_from_cam.linear().transpose() *
        result.trajectory.world_from_axis.linear().col(2);
    const double tilt_deg = rad2deg(std::acos(std::min(1.0, std::abs(axis_in_camera.normalized().y()))));
    add("axis", tilt_deg <= v.max_axis_tilt_deg, tilt_deg, v.max_axis_tilt_deg,
        fmt::format("the rotation axis is {:.1f} deg from the reference camera's vertical (at most {:.0f})", tilt_deg,
                    v.max_axis_tilt_deg));
  }

  verdict.checked = true;
  return verdict;
}

}  // namespace panoscan
