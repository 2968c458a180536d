// ORB front end of the joint tracking (paper §4.1); see frontend.h for what it does.
#include "panoscan/core/timer.h"
#include "panoscan/recon/frontend.h"

#include <algorithm>
#include <cstring>
#include <memory>
#include <chrono>
#include <cmath>
#include <map>
#include <numeric>

#include <fmt/format.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/recon/orb_features.h"
#include "cross_camera.h"

namespace panoscan {

void FrontendOptions::check(const std::string& origin) const {
  auto require = [&](bool ok, const char* field, const char* what) {
    if (!ok) throw make_error(origin, field, what);
  };
  require(orb_features >= 50 && orb_features <= 20000, "orb_features", "must be in [50, 20000]");
  require(orb_scale_factor > 1.0 && orb_scale_factor <= 2.0, "orb_scale_factor", "must be in (1, 2]");
  require(orb_levels >= 0 && orb_levels <= 16, "orb_levels", "must be in [0, 16] (0 = by the scan's motion)");
  require(max_hamming > 0 && max_hamming <= 256, "max_hamming", "must be in [1, 256]");
  require(ratio > 0.0 && ratio <= 1.0, "ratio", "must be in (0, 1]");
  require(same_camera_window >= 1, "same_camera_window", "must be >= 1");
  require(guide_keypoints >= 3, "guide_keypoints", "must be >= 3");
  require(guided_radius_px > 0.0, "guided_radius_px", "must be > 0");
  require(loop_frames >= 0, "loop_frames", "must be >= 0");
  require(ransac_iterations >= 1, "ransac_iterations", "must be >= 1");
  require(ransac_confidence > 0.0 && ransac_confidence <= 1.0, "ransac_confidence", "must be in (0, 1] (1 = every draw)");
  require(ransac_min_iterations >= 0, "ransac_min_iterations", "must be >= 0");
  require(ransac_sigmas > 0.0, "ransac_sigmas", "must be > 0");
  require(min_inliers >= 3 && min_cross_inliers >= 3, "min_inliers", "must be >= 3");
  require(min_depth_m > 0.0 && max_depth_m > min_depth_m, "min_depth_m", "need 0 < min_depth_m < max_depth_m");
  require(depth_noise_coefficient > 0.0, "depth_noise_coefficient", "must be > 0");
  require(threads >= 0, "threads", "must be >= 0");
  require(depth_grid_block >= 0 && depth_grid_block <= 64, "depth_grid_block", "must be in [0, 64] (0 = none)");
  require(loop_max_deviation_deg >= 0.0 && loop_max_deviation_deg <= 180.0, "loop_max_deviation_deg",
          "must be in [0, 180] (0 = no check)");
  require(loop_max_deviation_m >= 0.0, "loop_max_deviation_m", "must be >= 0 (0 = no check)");
  require(max_pair_translation_m > 0.0, "max_pair_translation_m", "must be > 0");
  require(band_patch_long_px >= 3 && band_patch_long_px <= 63, "band_patch_long_px", "must be in [3, 63]");
  require(band_patch_short_px >= 3 && band_patch_short_px <= band_patch_long_px, "band_patch_short_px",
          "must be in [3, band_patch_long_px]");
  require(band_search_deg > 0.0 && band_search_deg <= 5.0, "band_search_deg", "must be in (0, 5]");
  require(band_refine_px >= 1 && band_refine_px <= 20, "band_refine_px", "must be in [1, 20]");
  require(band_min_ncc > 0.0 && band_min_ncc < 1.0, "band_min_ncc", "must be in (0, 1)");
  require(band_min_contrast >= 0.0, "band_min_contrast", "must be >= 0");
  require(band_min_gradient >= 0.0, "band_min_gradient", "must be >= 0");
  require(band_peak_ratio >= 1.0, "band_peak_ratio", "must be >= 1");
  require(band_peak_margin >= 0.0, "band_peak_margin", "must be >= 0");
  require(band_max_shift_spread_px > 0.0, "band_max_shift_spread_px", "must be > 0");
  require(band_depth_slack_m >= 0.0, "band_depth_slack_m", "must be >= 0");
  require(band_frames >= 1 && band_frames <= 20, "band_frames", "must be in [1, 20]");
  require(band_calibration_pairs >= 1, "band_calibration_pairs", "must be >= 1");
  require(band_max_corners >= 1, "band_max_corners", "must be >= 1");
}

namespace {

FrameFeatures extract_features(const RgbdFrame& frame, const PinholeIntrinsics& intrinsics, const FrontendOptions& o) {
  FrameFeatures features;
  features.timestamp = frame.timestamp;
  const double area_scale = double(intrinsics.width) * intrinsics.height / (640.0 * 480.0);
  OrbDetectorOptions orb;
  orb.features = std::max(50, int(std::lround(o.orb_features * area_scale)));
  orb.scale_factor = o.orb_scale_factor;
  orb.levels = o.orb_levels;
  orb.fast_threshold = o.orb_fast_threshold;
  orb.patch_px = std::max(5, std::min(31, intrinsics.width / 20));
  orb.border_px = o.orb_border_px;  // 0 = the patch
  std::vector<OrbKeypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  detect_orb(frame.rgb, orb, &keypoints, &descriptors);
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const int x = int(std::lround(keypoints[i].u)), y = int(std::lround(keypoints[i].v));
    if (x < 0 || y < 0 || x >= frame.depth.width || y >= frame.depth.height) continue;
    const float z = frame.depth.data[std::size_t(y) * frame.depth.width + x];
    if (!(z >= o.min_depth_m && z <= o.max_depth_m)) continue;
    features.keypoints.push_back({keypoints[i].u, keypoints[i].v, z, keypoints[i].octave});
    features.descriptors.push_back(descriptors[i]);
  }
  return features;
}

struct PairTask {
  int sensor_a, frame_a, sensor_b, frame_b;
  FramePairMatch::Kind kind;
};

// How far a cross-camera candidate got (CrossCameraFunnel).
enum class CrossStage { kNone, kBand, kMatches, kRansac, kAccepted };

struct PairOutcome {
  bool accepted = false;
  bool guided = false, guided_fallback = false;  // same-camera and loop pairs: matched by projection / sample failed
  CrossStage cross_stage = CrossStage::kNone;
  int band_keypoints_a = 0, band_keypoints_b = 0, matches = 0, inliers = 0;
  FramePairMatch match;
  std::vector<std::pair<int, int>> keypoint_matches;  // inlier (keypoint a, keypoint b)
};

// Std of a back-projected keypoint (metres): depth noise (Handa) plus the ORB localisation error.
double point_sigma(const Keypoint& k, const PinholeIntrinsics& intrinsics, const FrontendOptions& o) {
  const double sigma_z = o.depth_noise_coefficient * k.depth * k.depth;
  const double sigma_px = std::pow(o.orb_scale_factor, k.octave);
  const double lateral = sigma_px * k.depth / intrinsics.fx;
  return std::sqrt(sigma_z * sigma_z + 2.0 * lateral * lateral);
}

// The back-projected matched keypoints of a and b and each pair's RANSAC inlier threshold (its
// 3D difference's std, from the depth noise and ORB's localisation, times ransac_sigmas).
void matched_points(const FrameFeatures& a, const FrameFeatures& b, const PinholeIntrinsics& in_a,
                    const PinholeIntrinsics& in_b, const FrontendOptions& options,
                    const std::vector<std::pair<int, int>>& matches, std::vector<Eigen::Vector3d>* pa,
                    std::vector<Eigen::Vector3d>* pb, std::vector<double>* thresholds) {
  for (const auto& [i, j] : matches) {
    const Keypoint& ka = a.keypoints[std::size_t(i)];
    const Keypoint& kb = b.keypoints[std::size_t(j)];
    pa->push_back(in_a.backproject(ka.u, ka.v, ka.depth));
    pb->push_back(in_b.backproject(kb.u, kb.v, kb.depth));
    const double sa = point_sigma(ka, in_a, options), sb = point_sigma(kb, in_b, options);
    thresholds->push_back(std::max(options.ransac_min_threshold_m, options.ransac_sigmas * std::hypot(sa, sb)));
  }
}

// Matching by projection (ORB-SLAM's "search by projection", Mur-Artal et al. 2015), for
// same-camera and loop pairs: brute force compares every keypoint of a with every one of b, ~10^6
// Hamming distances per pair, a fifth of the front end's instructions. Both frames of such a pair
// see most of one view (consecutive frames; the start and the end of the turn), so
// guide_keypoints of a, spread over its list (ORB orders it by pyramid level, then response),
// matched against all of b and verified by the same RANSAC, predict a_from_b; each keypoint of a,
// moved by it with its own depth, is then compared only with b's keypoints within the search
// radius of where it lands (the same ratio test and one-a-per-b rule, among those). The prediction
// is only a search window: the pair's transform is still RANSAC's over all the guided matches.
// Returns false (the caller matches brute force) when a has too few keypoints for a sample to save
// work or the sample does not verify (a frame of plain wall).
bool match_by_projection(const FrameFeatures& a, const FrameFeatures& b, const PinholeIntrinsics& in_a,
                         const PinholeIntrinsics& in_b, const FrontendOptions& options, std::int64_t key,
                         std::vector<std::pair<int, int>>* matches) {
  const int count_a = int(a.keypoints.size()), count_b = int(b.keypoints.size());
  // The sample scales with the image area, as the keypoints do (extract_features).
  const double area_scale = double(in_a.width) * in_a.height / (640.0 * 480.0);
  const int sample_size = std::max(5 * options.min_inliers, int(std::lround(options.guide_keypoints * area_scale)));
  if (count_a < 2 * sample_size || count_b < options.min_inliers) return false;
  std::vector<int> sample(static_cast<std::size_t>(sample_size)), all_b(static_cast<std::size_t>(count_b));
  for (int k = 0; k < sample_size; ++k) sample[std::size_t(k)] = int(std::int64_t(k) * count_a / sample_size);
  std::iota(all_b.begin(), all_b.end(), 0);
  const auto sample_matches =
      match_orb(a.descriptors, sample, b.descriptors, all_b, {options.max_hamming, options.ratio});
  if (int(sample_matches.size()) < options.min_inliers) return false;
  std::vector<Eigen::Vector3d> pa, pb;
  std::vector<double> thresholds;
  matched_points(a, b, in_a, in_b, options, sample_matches, &pa, &pb, &thresholds);
  RigidRansacResult predicted;
  // Its own random stream (negative keys are not used by the pairs' RANSAC), and at most half the
  // pair's iterations: the sample's matches are mostly right (at 80% inliers about every second draw
  // is all inliers; at 50%, 100 draws all miss with probability 1e-6).
  const RansacBudget budget{std::max(1, options.ransac_iterations / 2), options.ransac_confidence,
                            options.ransac_min_iterations};
  if (!rigid_ransac(pa, pb, thresholds, budget, options.min_inliers, options.seed, -1 - key, &predicted))
    return false;
  const Rigid3d b_from_a = predicted.a_from_b.inverse();

  // b's keypoints in a grid of radius-sized cells: a window touches at most 3 x 3 cells.
  const double radius = options.guided_radius_px * in_b.width / 640.0;
  const int columns = std::max(1, int(std::ceil(in_b.width / radius)));
  const int rows = std::max(1, int(std::ceil(in_b.height / radius)));
  auto cell_of = [&](double u, double v, int* cx, int* cy) {
    *cx = std::clamp(int(std::floor(u / radius)), 0, columns - 1);
    *cy = std::clamp(int(std::floor(v / radius)), 0, rows - 1);
  };
  std::vector<int> cell_start(static_cast<std::size_t>(columns) * rows + 1, 0);
  std::vector<int> cell_items(static_cast<std::size_t>(count_b)), cell_index(static_cast<std::size_t>(count_b));
  for (int j = 0; j < count_b; ++j) {
    int cx, cy;
    cell_of(b.keypoints[std::size_t(j)].u, b.keypoints[std::size_t(j)].v, &cx, &cy);
    cell_index[std::size_t(j)] = cy * columns + cx;
    ++cell_start[std::size_t(cell_index[std::size_t(j)]) + 1];
  }
  for (std::size_t c = 1; c < cell_start.size(); ++c) cell_start[c] += cell_start[c - 1];
  {
    std::vector<int> fill(cell_start.begin(), cell_start.end() - 1);
    for (int j = 0; j < count_b; ++j) cell_items[std::size_t(fill[std::size_t(cell_index[std::size_t(j)])]++)] = j;
  }
  std::vector<int> offsets{0}, candidates;
  offsets.reserve(std::size_t(count_a) + 1);
  const double radius2 = radius * radius;
  for (int i = 0; i < count_a; ++i) {
    const Keypoint& k = a.keypoints[std::size_t(i)];
    const Eigen::Vector3d p = b_from_a * in_a.backproject(k.u, k.v, k.depth);
    if (p.z() > 0.05) {
      const Eigen::Vector2d px = in_b.project(p);
      int cx, cy;
      cell_of(px.x(), px.y(), &cx, &cy);
      for (int y = std::max(0, cy - 1); y <= std::min(rows - 1, cy + 1); ++y)
        for (int x = std::max(0, cx - 1); x <= std::min(columns - 1, cx + 1); ++x) {
          const int c = y * columns + x;
          for (int s = cell_start[std::size_t(c)]; s < cell_start[std::size_t(c) + 1]; ++s) {
            const int j = cell_items[std::size_t(s)];
            const double du = b.keypoints[std::size_t(j)].u - px.x(), dv = b.keypoints[std::size_t(j)].v - px.y();
            if (du * du + dv * dv <= radius2) candidates.push_back(j);
          }
        }
    }
    offsets.push_back(int(candidates.size()));
  }
  *matches = match_orb_among(a.descriptors, b.descriptors, offsets, candidates, {options.max_hamming, options.ratio});
  return true;
}

// Step 2: the candidate frame pairs of each camera in a fixed order: each frame with the previous
// same_camera_window frames of its camera, the last loop_frames of each camera with its first
// ones. (Pairs across cameras come later, once the chains predict the rig's motion: step 5.)
std::vector<PairTask> candidate_pairs(const ScanIndex& scan, const std::vector<char>& used,
                                      const FrontendOptions& options) {
  const int sensor_count = int(scan.rig.sensors.size());
  std::vector<PairTask> tasks;
  for (int s = 0; s < sensor_count; ++s) {
    if (!used[s]) continue;
    const int n = int(scan.frames[s].size());
    for (int f = 1; f < n; ++f)
      for (int w = 1; w <= options.same_camera_window && f - w >= 0; ++w)
        tasks.push_back({s, f - w, s, f, FramePairMatch::Kind::kSameCamera});
    if (options.loop_closure && n > 4 * options.loop_frames)
      for (int a = 0; a < options.loop_frames; ++a)
        for (int b = n - options.loop_frames; b < n; ++b) tasks.push_back({s, a, s, b, FramePairMatch::Kind::kLoop});
  }

  return tasks;
}

// Step 3: one candidate pair matched (ratio test inside the overlap band for cross-camera pairs)
// and verified by 3D-3D RANSAC (and, across cameras, against the predicted transform).
// `predicted_a_from_b` (cross-camera pairs only): the calibration and the rig's motion between the
// two shutter times (cross_camera::predict_b_from_a).
PairOutcome match_pair(const PairTask& task, const std::vector<std::vector<FrameFeatures>>& features,
                       const ScanIndex& scan, const FrontendOptions& options,
                       const Rigid3d& predicted_a_from_b = Rigid3d::Identity()) {
  PairOutcome out;
  const FrameFeatures& a = features[task.sensor_a][task.frame_a];
  const FrameFeatures& b = features[task.sensor_b][task.frame_b];
  const auto& in_a = scan.rig.sensors[task.sensor_a].intrinsics;
  const auto& in_b = scan.rig.sensors[task.sensor_b].intrinsics;
  const bool cross = task.kind == FramePairMatch::Kind::kCrossCamera;
  const int min_inliers = cross ? options.min_cross_inliers : options.min_inliers;
  if (int(a.keypoints.size()) < min_inliers || int(b.keypoints.size()) < min_inliers) return out;
  auto point = [](const Keypoint& kp, const PinholeIntrinsics& in) { return in.backproject(kp.u, kp.v, kp.depth); };
  std::vector<int> subset_a, subset_b;
  if (cross) {
    // The narrow overlap band: keypoints that project into the other camera (predicted transform).
    const double m = options.cross_overlap_margin_px;
    auto inside = [m](const PinholeIntrinsics& in, const Eigen::Vector3d& p) {
      if (p.z() <= 0.05) return false;
      const Eigen::Vector2d px = in.project(p);
      return px.x() >= -m && px.y() >= -m && px.x() <= in.width - 1 + m && px.y() <= in.height - 1 + m;
    };
    for (int i = 0; i < int(a.keypoints.size()); ++i)
      if (inside(in_b, predicted_a_from_b.inverse() * point(a.keypoints[i], in_a))) subset_a.push_back(i);
    for (int j = 0; j < int(b.keypoints.size()); ++j)
      if (inside(in_a, predicted_a_from_b * point(b.keypoints[j], in_b))) subset_b.push_back(j);
    out.band_keypoints_a = int(subset_a.size());
    out.band_keypoints_b = int(subset_b.size());
    if (int(subset_a.size()) < min_inliers || int(subset_b.size()) < min_inliers) return out;
    out.cross_stage = CrossStage::kBand;
  } else {
    subset_a.resize(a.keypoints.size());
    std::iota(subset_a.begin(), subset_a.end(), 0);
    subset_b.resize(b.keypoints.size());
    std::iota(subset_b.begin(), subset_b.end(), 0);
  }
  const std::int64_t key = (std::int64_t(task.sensor_a) * 8 + task.sensor_b) * 100000000LL +
                           std::int64_t(task.frame_a) * 10000 + (task.frame_b % 10000);
  std::vector<std::pair<int, int>> matches;
  if (!cross && options.guided_matching) {
    out.guided = match_by_projection(a, b, in_a, in_b, options, key, &matches);
    out.guided_fallback = !out.guided;
  }
  if (!out.guided)
    matches = match_orb(a.descriptors, subset_a, b.descriptors, subset_b, {options.max_hamming, options.ratio});
  out.matches = int(matches.size());
  if (int(matches.size()) < min_inliers) return out;
  if (cross) out.cross_stage = CrossStage::kMatches;
  std::vector<Eigen::Vector3d> pa, pb;
  std::vector<double> thresholds;
  matched_points(a, b, in_a, in_b, options, matches, &pa, &pb, &thresholds);
  RigidRansacResult ransac;
  const bool found =
      rigid_ransac(pa, pb, thresholds, {options.ransac_iterations, options.ransac_confidence, options.ransac_min_iterations},
                   min_inliers, options.seed, key, &ransac);
  out.inliers = int(ransac.inliers.size());
  if (!found) return out;
  if (cross) {
    out.cross_stage = CrossStage::kRansac;
    const Rigid3d deviation = predicted_a_from_b.inverse() * ransac.a_from_b;
    if (rad2deg(rotation_angle(deviation.linear())) > options.cross_max_deviation_deg ||
        deviation.translation().norm() > options.cross_max_deviation_m)
      return out;
    out.cross_stage = CrossStage::kAccepted;
  }
  out.accepted = true;
  out.match = {task.sensor_a,
               task.frame_a,
               task.sensor_b,
               task.frame_b,
               ransac.a_from_b,
               int(ransac.inliers.size()),
               task.kind,
               {},
               {},
               {}};
  for (int i : ransac.inliers) {
    out.keypoint_matches.push_back(matches[std::size_t(i)]);
    out.match.points_a.push_back(pa[std::size_t(i)]);
    out.match.points_b.push_back(pb[std::size_t(i)]);
    out.match.thresholds.push_back(thresholds[std::size_t(i)]);
  }
  return out;
}

// Step 3b: pairs the geometry of an in-place rotator rules out, un-accepted (frontend.h, "A room
// with repeated objects"):
//  - every same-camera or loop pair that moves the camera farther than max_pair_translation_m;
//  - a loop pair whose rotation disagrees with the chain of the camera's accepted same-camera
//    transforms (frame f from the nearest earlier frame with a pose and a pair to f; a frame with
//    none starts a new chain) by more than loop_max_deviation_deg;
//  - a loop pair whose translation is not the rotator's: a camera turning about a fixed line moves
//    as x_a = R (x_b - p) + p, so a_from_b's translation is (I - R) p, with p a point of the axis in
//    the camera's frame, the same for all its frames; p is the least-squares fit to the camera's
//    same-camera pairs, and the loop pair may miss (I - R) p by loop_max_deviation_m: RANSAC's
//    translation carries its rotation error times the distance to the points (0.5 deg at 3 m is
//    26 mm; valid loop pairs miss by up to 48 mm on generated office 3), an object matched onto its
//    twin by its distance to it.
// Pairs stay in task order, so the result is independent of the thread count.
// The chains are also what predicts the rig's motion between two cameras' shutter times (step 5):
// they are returned in *chains.
void reject_implausible_pairs(const std::vector<PairTask>& tasks, std::vector<PairOutcome>& outcomes,
                              const ScanIndex& scan, const FrontendOptions& options, FrontendResult& result,
                              cross_camera::CameraChains* chains_out) {
  const int sensor_count = int(scan.rig.sensors.size());
  std::map<std::array<int, 3>, int> same_camera;  // (sensor, frame a, frame b) -> task
  std::vector<Eigen::Matrix3d> normal(sensor_count, Eigen::Matrix3d::Zero());
  std::vector<Eigen::Vector3d> rhs(sensor_count, Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < tasks.size(); ++k) {
    PairOutcome& out = outcomes[k];
    if (!out.accepted || tasks[k].kind == FramePairMatch::Kind::kCrossCamera) continue;
    if (out.match.a_from_b.translation().norm() > options.max_pair_translation_m) {
      out.accepted = false;
      ++result.rejected_far_pairs;
      continue;
    }
    if (tasks[k].kind != FramePairMatch::Kind::kSameCamera) continue;
    const int s = tasks[k].sensor_a;
    same_camera[{s, tasks[k].frame_a, tasks[k].frame_b}] = int(k);
    const Eigen::Matrix3d a = Eigen::Matrix3d::Identity() - out.match.a_from_b.linear();
    normal[s] += a.transpose() * a;
    rhs[s] += a.transpose() * out.match.a_from_b.translation();
  }
  // The axis point of each camera; its component along the axis is free ((I - R) removes it):
  // the minimum-norm solution.
  std::vector<Eigen::Vector3d> axis_point(sensor_count, Eigen::Vector3d::Zero());
  std::vector<char> has_axis_point(sensor_count, 0);
  for (int s = 0; s < sensor_count; ++s) {
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(normal[s], Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Vector3d sv = svd.singularValues();
    if (!(sv(1) > 1e-6)) continue;  // fewer than two independent turns
    Eigen::Vector3d inverse_sv = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) inverse_sv(i) = sv(i) > 1e-3 * sv(0) ? 1.0 / sv(i) : 0.0;
    axis_point[s] = svd.matrixV() * inverse_sv.asDiagonal() * svd.matrixU().transpose() * rhs[s];
    has_axis_point[s] = 1;
  }
  std::vector<std::vector<Rigid3d>>& chain_from_frame = chains_out->chain_from_frame;
  std::vector<std::vector<int>>& chain_of_frame = chains_out->chain_of_frame;
  chain_from_frame.assign(sensor_count, {});
  chain_of_frame.assign(sensor_count, {});
  chains_out->timestamps.assign(sensor_count, {});
  for (int s = 0; s < sensor_count; ++s)
    for (const FrameEntry& e : scan.frames[s]) chains_out->timestamps[s].push_back(e.timestamp);
  int chains = 0;
  for (int s = 0; s < sensor_count; ++s) {
    const int n = int(scan.frames[s].size());
    chain_from_frame[s].assign(n, Rigid3d::Identity());
    chain_of_frame[s].assign(n, -1);
    for (int f = 0; f < n; ++f) {
      for (int w = 1; w <= options.same_camera_window && f - w >= 0; ++w) {
        const auto it = same_camera.find({s, f - w, f});
        if (it == same_camera.end() || chain_of_frame[s][f - w] < 0) continue;
        chain_from_frame[s][f] = chain_from_frame[s][f - w] * outcomes[it->second].match.a_from_b;
        chain_of_frame[s][f] = chain_of_frame[s][f - w];
        break;
      }
      if (chain_of_frame[s][f] < 0) chain_of_frame[s][f] = chains++;
    }
  }
  for (std::size_t k = 0; k < tasks.size(); ++k) {
    PairOutcome& out = outcomes[k];
    const PairTask& task = tasks[k];
    if (!out.accepted || task.kind != FramePairMatch::Kind::kLoop) continue;
    const int s = task.sensor_a;
    const Rigid3d& a_from_b = out.match.a_from_b;
    double angle_deg = 0.0, miss_m = 0.0;
    if (chain_of_frame[s][task.frame_a] == chain_of_frame[s][task.frame_b]) {
      const Rigid3d chained = chain_from_frame[s][task.frame_a].inverse() * chain_from_frame[s][task.frame_b];
      angle_deg = rad2deg(rotation_angle(chained.linear().transpose() * a_from_b.linear()));
    }
    if (has_axis_point[s])
      miss_m = (a_from_b.translation() - (Eigen::Matrix3d::Identity() - a_from_b.linear()) * axis_point[s]).norm();
    const bool agrees = (options.loop_max_deviation_deg <= 0.0 || angle_deg <= options.loop_max_deviation_deg) &&
                        (options.loop_max_deviation_m <= 0.0 || miss_m <= options.loop_max_deviation_m);
    log_debug(fmt::format(
        "{}: loop pair cam{} {}-{}: rotation {:.2f} deg from the chained transforms, translation "
        "{:.1f} mm from the rotator's{}",
        scan.root.string(), s, task.frame_a, task.frame_b, angle_deg, 1e3 * miss_m, agrees ? "" : ": rejected"));
    if (!agrees) {
      out.accepted = false;
      ++result.rejected_loop_pairs;
    }
  }
}

// Step 4: the accepted pairs in task order, and the landmarks as union-find tracks over the
// matched keypoints of all frames (at most one observation per frame).
void build_landmarks(const std::vector<PairOutcome>& outcomes, FrontendResult& result) {
  const int sensor_count = int(result.features.size());
  std::vector<std::vector<int>> offset(sensor_count);
  int total = 0;
  for (int s = 0; s < sensor_count; ++s) {
    offset[s].resize(result.features[s].size());
    for (std::size_t f = 0; f < result.features[s].size(); ++f) {
      offset[s][f] = total;
      total += int(result.features[s][f].keypoints.size());
    }
  }
  std::vector<int> parent(total);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const PairOutcome& out : outcomes) {
    if (!out.accepted) continue;
    result.pairs.push_back(out.match);
    switch (out.match.kind) {
      case FramePairMatch::Kind::kSameCamera: ++result.same_camera_pairs; break;
      case FramePairMatch::Kind::kCrossCamera: ++result.cross_camera_pairs; break;
      case FramePairMatch::Kind::kLoop: ++result.loop_pairs; break;
    }
    for (const auto& [i, j] : out.keypoint_matches) {
      const int x = find(offset[out.match.sensor_a][out.match.frame_a] + i);
      const int y = find(offset[out.match.sensor_b][out.match.frame_b] + j);
      if (x != y) parent[std::max(x, y)] = std::min(x, y);
    }
  }
  result.cross_landmarks.assign(sensor_count, 0);
  result.cross_observations.assign(sensor_count, 0);
  std::map<int, std::vector<Observation>> tracks;
  for (int s = 0; s < sensor_count; ++s)
    for (std::size_t f = 0; f < result.features[s].size(); ++f)
      for (int k = 0; k < int(result.features[s][f].keypoints.size()); ++k) {
        const int node = offset[s][f] + k;
        tracks[find(node)].push_back({s, int(f), k});
      }
  for (auto& [root, observations] : tracks) {
    if (observations.size() < 2) continue;
    // At most one observation per frame (a track that merged two keypoints of one frame keeps the first).
    std::vector<Observation> kept;
    for (const Observation& o : observations)
      if (kept.empty() || kept.back().sensor != o.sensor || kept.back().frame != o.frame) kept.push_back(o);
    if (kept.size() < 2) continue;
    std::vector<int> per_sensor(sensor_count, 0);
    for (const Observation& o : kept) ++per_sensor[o.sensor];
    const int sensors_seeing = int(std::count_if(per_sensor.begin(), per_sensor.end(), [](int n) { return n > 0; }));
    if (sensors_seeing >= 2)
      for (int s = 0; s < sensor_count; ++s)
        if (per_sensor[s] > 0) {
          ++result.cross_landmarks[s];
          result.cross_observations[s] += per_sensor[s];
        }
    result.landmarks.push_back(std::move(kept));
  }
}

// The crops each relation needs: [relation][0 = camera a, 1 = camera b][frame].
using RelationCrops = std::vector<std::array<std::vector<cross_camera::BandCrop>, 2>>;

// Index of a keypoint of `features` within 1 px of (u, v), appended (no descriptor: it is never
// matched by descriptor) if there is none; a band match on an ORB keypoint joins its track.
int keypoint_at(FrameFeatures& features, const Keypoint& k, std::size_t orb_count) {
  for (std::size_t i = 0; i < features.keypoints.size(); ++i) {
    const Keypoint& e = features.keypoints[i];
    if (std::abs(e.u - k.u) <= 1.0f && std::abs(e.v - k.v) <= 1.0f && (i < orb_count || (e.u == k.u && e.v == k.v)))
      return int(i);
  }
  features.keypoints.push_back(k);
  features.descriptors.push_back(OrbDescriptor{});
  return int(features.keypoints.size()) - 1;
}

// Step 5: pairs across cameras, for each overlapping camera pair (cross_camera.h): the band's
// rotation error first, then each frame of a with the frame of b closest in time by ORB inside the
// predicted band (cross_camera) and with the band_frames closest ones by band alignment
// (band_matching). All matching runs first, on the ORB keypoints only; the band matches are then
// appended as keypoints in task order (independent of the thread count).
std::vector<PairOutcome> match_across_cameras(const ScanIndex& scan, const FrontendOptions& options,
                                              const std::vector<cross_camera::Relation>& relations,
                                              const RelationCrops& crops, const cross_camera::CameraChains& chains,
                                              FrontendResult& result) {
  struct CrossTask {
    int relation, frame_a, frame_b;
    bool orb, band;
  };
  std::vector<CrossTask> tasks;
  std::vector<Rigid3d> b_from_a_instant(relations.size());
  CrossCameraFunnel& funnel = result.cross_camera;
  for (std::size_t r = 0; r < relations.size(); ++r) {
    const cross_camera::Relation& relation = relations[r];
    const std::vector<double>& ta = chains.timestamps[relation.sensor_a];
    const std::vector<double>& tb = chains.timestamps[relation.sensor_b];
    if (ta.empty() || tb.empty()) continue;
    // Frames of b in order of their time distance to frame f of a (nearest first).
    auto nearest = [&](int f, int count) {
      const int g0 = int(std::lower_bound(tb.begin(), tb.end(), ta[f]) - tb.begin());
      std::vector<int> near;
      for (int g = std::max(0, g0 - count); g < std::min(int(tb.size()), g0 + count + 1); ++g) near.push_back(g);
      std::stable_sort(near.begin(), near.end(),
                       [&](int x, int y) { return std::abs(tb[x] - ta[f]) < std::abs(tb[y] - ta[f]); });
      if (int(near.size()) > count) near.resize(count);
      return near;
    };
    const int frames_a = int(ta.size());
    b_from_a_instant[r] = relation.b_from_a_calibrated;
    CrossCameraFunnel::BandRelation report{relation.sensor_a, relation.sensor_b, 0, 0.0};
    if (options.band_matching) {
      std::vector<std::pair<int, int>> sample;
      std::vector<const cross_camera::BandCrop*> crops_a, crops_b;
      const int step = std::max(1, frames_a / std::max(1, options.band_calibration_pairs));
      for (int f = 0; f < frames_a; f += step)
        for (int g : nearest(f, options.band_frames)) {
          sample.push_back({f, g});
          crops_a.push_back(&crops[r][0][f]);
          crops_b.push_back(&crops[r][1][g]);
        }
      const Eigen::Matrix3d correction = cross_camera::estimate_band_correction(relation, chains, sample, crops_a,
                                                                                crops_b, scan, options, &report.votes);
      b_from_a_instant[r] = make_rigid(correction, Eigen::Vector3d::Zero()) * relation.b_from_a_calibrated;
      report.correction_deg = rad2deg(rotation_angle(correction));
    }
    funnel.band_relations.push_back(report);
    for (int f = 0; f < frames_a; ++f) {
      const std::vector<int> near = nearest(f, std::max(1, options.band_frames));
      for (std::size_t k = 0; k < near.size(); ++k) {
        const bool orb = options.cross_camera && k == 0, band = options.band_matching && int(k) < options.band_frames;
        if (orb || band) tasks.push_back({int(r), f, near[k], orb, band});
      }
    }
  }
  struct CrossOutcome {
    bool predicted = false;
    PairOutcome orb;
    cross_camera::BandPairResult band;
  };
  std::vector<CrossOutcome> outcomes(tasks.size());
  tbb::parallel_for(std::size_t(0), tasks.size(), [&](std::size_t k) {
    const CrossTask& task = tasks[k];
    const cross_camera::Relation& relation = relations[task.relation];
    Rigid3d b_from_a;
    if (!cross_camera::predict_b_from_a(chains, relation, b_from_a_instant[task.relation], task.frame_a, task.frame_b,
                                        &b_from_a))
      return;
    outcomes[k].predicted = true;
    if (task.orb)
      outcomes[k].orb = match_pair(
          {relation.sensor_a, task.frame_a, relation.sensor_b, task.frame_b, FramePairMatch::Kind::kCrossCamera},
          result.features, scan, options, b_from_a.inverse());
    if (task.band)
      outcomes[k].band = cross_camera::match_band_pair(relation, b_from_a, crops[task.relation][0][task.frame_a],
                                                       crops[task.relation][1][task.frame_b], scan, options);
  });
  std::vector<std::vector<std::size_t>> orb_count(result.features.size());
  for (std::size_t s = 0; s < result.features.size(); ++s)
    for (const FrameFeatures& f : result.features[s]) orb_count[s].push_back(f.keypoints.size());
  std::vector<PairOutcome> accepted;
  for (std::size_t k = 0; k < tasks.size(); ++k) {
    const CrossTask& task = tasks[k];
    const cross_camera::Relation& relation = relations[task.relation];
    const CrossOutcome& out = outcomes[k];
    if (task.orb) {
      ++funnel.candidates;
      funnel.unpredicted += !out.predicted;
      funnel.with_band_keypoints += out.orb.cross_stage >= CrossStage::kBand;
      funnel.with_matches += out.orb.cross_stage >= CrossStage::kMatches;
      funnel.with_ransac += out.orb.cross_stage >= CrossStage::kRansac;
      funnel.accepted += out.orb.cross_stage >= CrossStage::kAccepted;
      funnel.band_keypoints_a += out.orb.band_keypoints_a;
      funnel.band_keypoints_b += out.orb.band_keypoints_b;
      funnel.matches += out.orb.matches;
      funnel.inliers += out.orb.inliers;
      if (out.orb.accepted) accepted.push_back(out.orb);
    }
    if (!task.band) continue;
    ++funnel.band_candidates;
    funnel.band_unpredicted += !out.predicted;
    funnel.band_with_anchors += out.band.anchors >= options.min_cross_inliers;
    funnel.band_anchors += out.band.anchors;
    funnel.band_aligned += out.band.aligned;
    if (out.band.matches.empty()) continue;
    ++funnel.band_accepted;
    funnel.band_matches += out.band.matches.size();
    PairOutcome pair;
    pair.accepted = true;
    pair.match = {relation.sensor_a,
                  task.frame_a,
                  relation.sensor_b,
                  task.frame_b,
                  out.band.a_from_b,
                  int(out.band.matches.size()),
                  FramePairMatch::Kind::kCrossCamera,
                  {},
                  {},
                  {}};
    FrameFeatures& fa = result.features[relation.sensor_a][task.frame_a];
    FrameFeatures& fb = result.features[relation.sensor_b][task.frame_b];
    for (const cross_camera::BandMatch& m : out.band.matches)
      pair.keypoint_matches.push_back({keypoint_at(fa, m.in_a, orb_count[relation.sensor_a][task.frame_a]),
                                       keypoint_at(fb, m.in_b, orb_count[relation.sensor_b][task.frame_b])});
    matched_points(fa, fb, scan.rig.sensors[std::size_t(relation.sensor_a)].intrinsics,
                   scan.rig.sensors[std::size_t(relation.sensor_b)].intrinsics, options, pair.keypoint_matches,
                   &pair.match.points_a, &pair.match.points_b, &pair.match.thresholds);
    accepted.push_back(std::move(pair));
  }
  return accepted;
}

}  // namespace

int orb_levels_for(const FrontendOptions& options, RigMotion motion) {
  if (options.orb_levels > 0) return options.orb_levels;
  return motion == RigMotion::kHandheld ? kHandheldOrbLevels : kRotatorOrbLevels;
}

FrontendResult run_frontend(const ScanIndex& scan, const FrontendOptions& requested) {
  requested.check();
  FrontendOptions options = requested;
  options.orb_levels = orb_levels_for(requested, scan.rig.motion);
  const auto start = std::chrono::steady_clock::now();
  std::unique_ptr<tbb::global_control> limit;
  if (options.threads > 0)
    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, options.threads);
  const int sensor_count = int(scan.rig.sensors.size());
  std::vector<char> used(sensor_count, options.sensors.empty() ? 1 : 0);
  for (int s : options.sensors) {
    if (s < 0 || s >= sensor_count) throw make_error(scan.root.string(), "sensors", "sensor index out of range");
    used[s] = 1;
  }
  FrontendResult result;
  result.orb_levels = options.orb_levels;
  result.features.resize(sensor_count);
  std::vector<std::pair<int, int>> frame_list;
  for (int s = 0; s < sensor_count; ++s) {
    result.features[s].resize(scan.frames[s].size());
    if (options.depth_grid_block > 0) result.depth_grids.emplace_back(scan.frames[s].size());
    if (used[s])
      for (int f = 0; f < int(scan.frames[s].size()); ++f) frame_list.push_back({s, f});
  }
  const std::vector<cross_camera::Relation> relations = options.cross_camera || options.band_matching
                                                            ? cross_camera::overlapping_relations(scan, used, options)
                                                            : std::vector<cross_camera::Relation>{};
  RelationCrops crops(relations.size());
  if (options.band_matching)
    for (std::size_t r = 0; r < relations.size(); ++r) {
      crops[r][0].resize(scan.frames[relations[r].sensor_a].size());
      crops[r][1].resize(scan.frames[relations[r].sensor_b].size());
    }

  // 1. Features and the overlap crops (one task per frame).
  tbb::parallel_for(std::size_t(0), frame_list.size(), [&](std::size_t k) {
    const auto [s, f] = frame_list[k];
    const RgbdFrame frame = load_frame(scan, s, std::size_t(f));
    result.features[s][f] = extract_features(frame, scan.rig.sensors[s].intrinsics, options);
    if (options.depth_grid_block > 0)
      result.depth_grids[s][f] = make_depth_grid(frame.depth, scan.rig.sensors[s].intrinsics, options.depth_grid_block,
                                                 options.depth_noise_coefficient);
    if (!options.band_matching) return;
    for (std::size_t r = 0; r < relations.size(); ++r) {
      if (relations[r].sensor_a == s)
        crops[r][0][f] = cross_camera::make_band_crop(frame, relations[r], true, options);
      if (relations[r].sensor_b == s)
        crops[r][1][f] = cross_camera::make_band_crop(frame, relations[r], false, options);
    }
  });
  const auto features_done = std::chrono::steady_clock::now();
  for (const auto& [s, f] : frame_list)
    if (int(result.features[s][f].keypoints.size()) < options.min_inliers) ++result.frames_without_features;

  // 2. Candidate pairs of each camera in a fixed order; 3. matched and verified (one task per
  // pair); 4. implausible pairs rejected, the chains built; 5. pairs across cameras; 6. landmarks.
  const std::vector<PairTask> tasks = candidate_pairs(scan, used, options);
  std::vector<PairOutcome> outcomes(tasks.size());
  tbb::parallel_for(std::size_t(0), tasks.size(),
                    [&](std::size_t k) { outcomes[k] = match_pair(tasks[k], result.features, scan, options); });
  for (const PairOutcome& out : outcomes) {
    result.guided_pairs += out.guided ? 1 : 0;
    result.guided_fallbacks += out.guided_fallback ? 1 : 0;
  }
  cross_camera::CameraChains chains;
  reject_implausible_pairs(tasks, outcomes, scan, options, result, &chains);
  for (PairOutcome& out : match_across_cameras(scan, options, relations, crops, chains, result))
    outcomes.push_back(std::move(out));
  build_landmarks(outcomes, result);
  const auto done = std::chrono::steady_clock::now();
  const double frames = std::max<std::size_t>(1, frame_list.size());
  result.feature_ms_per_frame = std::chrono::duration<double, std::milli>(features_done - start).count() / frames;
  result.matching_ms_per_frame = std::chrono::duration<double, std::milli>(done - features_done).count() / frames;
  result.total_seconds = seconds_between(start, done);
  return result;
}

}  // namespace panoscan
