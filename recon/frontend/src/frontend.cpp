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
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"

namespace panoscan {

void FrontendOptions::check(const std::string& origin) const {
  auto require = [&](bool ok, const char* field, const char* what) {
    if (!ok) throw make_error(origin, field, what);
  };
  require(orb_features >= 50 && orb_features <= 20000, "orb_features", "must be in [50, 20000]");
  require(orb_scale_factor > 1.0 && orb_scale_factor <= 2.0, "orb_scale_factor", "must be in (1, 2]");
  require(orb_levels >= 1 && orb_levels <= 16, "orb_levels", "must be in [1, 16]");
  require(max_hamming > 0 && max_hamming <= 256, "max_hamming", "must be in [1, 256]");
  require(ratio > 0.0 && ratio <= 1.0, "ratio", "must be in (0, 1]");
  require(same_camera_window >= 1, "same_camera_window", "must be >= 1");
  require(loop_frames >= 0, "loop_frames", "must be >= 0");
  require(ransac_iterations >= 1, "ransac_iterations", "must be >= 1");
  require(ransac_sigmas > 0.0, "ransac_sigmas", "must be > 0");
  require(min_inliers >= 3 && min_cross_inliers >= 3, "min_inliers", "must be >= 3");
  require(min_depth_m > 0.0 && max_depth_m > min_depth_m, "min_depth_m", "need 0 < min_depth_m < max_depth_m");
  require(depth_noise_coefficient > 0.0, "depth_noise_coefficient", "must be > 0");
  require(threads >= 0, "threads", "must be >= 0");
  require(loop_max_deviation_deg >= 0.0 && loop_max_deviation_deg <= 180.0, "loop_max_deviation_deg",
          "must be in [0, 180] (0 = no check)");
  require(loop_max_deviation_m >= 0.0, "loop_max_deviation_m", "must be >= 0 (0 = no check)");
  require(max_pair_translation_m > 0.0, "max_pair_translation_m", "must be > 0");
}

namespace {

using Descriptor = std::array<std::uint8_t, 32>;

// Inlined into match_descriptors, which is compiled twice on x86-64 (below).
inline int hamming(const Descriptor& a, const Descriptor& b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a.data() + i, 8);
    std::memcpy(&y, b.data() + i, 8);
    distance += __builtin_popcountll(x ^ y);
  }
  return distance;
}

FrameFeatures extract_features(const RgbdFrame& frame, const PinholeIntrinsics& intrinsics, const FrontendOptions& o) {
  FrameFeatures features;
  features.timestamp = frame.timestamp;
  cv::Mat rgb(frame.rgb.height, frame.rgb.width, CV_8UC3, const_cast<std::uint8_t*>(frame.rgb.data.data()));
  cv::Mat gray;
  cv::cvtColor(rgb, gray, cv::COLOR_RGB2GRAY);
  const double area_scale = double(intrinsics.width) * intrinsics.height / (640.0 * 480.0);
  const int wanted = std::max(50, int(std::lround(o.orb_features * area_scale)));
  const int patch = std::max(5, std::min(31, intrinsics.width / 20));
  const int border = o.orb_border_px > 0 ? o.orb_border_px : patch;
  auto orb = cv::ORB::create(wanted, float(o.orb_scale_factor), o.orb_levels, border, 0, 2, cv::ORB::HARRIS_SCORE,
                             patch, o.orb_fast_threshold);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  orb->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
  for (std::size_t i = 0; i < keypoints.size(); ++i) {
    const int x = int(std::lround(keypoints[i].pt.x)), y = int(std::lround(keypoints[i].pt.y));
    if (x < 0 || y < 0 || x >= frame.depth.width || y >= frame.depth.height) continue;
    const float z = frame.depth.data[std::size_t(y) * frame.depth.width + x];
    if (!(z >= o.min_depth_m && z <= o.max_depth_m)) continue;
    features.keypoints.push_back({keypoints[i].pt.x, keypoints[i].pt.y, z, keypoints[i].octave});
    Descriptor d;
    std::memcpy(d.data(), descriptors.ptr<std::uint8_t>(int(i)), 32);
    features.descriptors.push_back(d);
  }
  return features;
}

// Mutual-free nearest neighbour with a ratio test, a -> b, restricted to the candidate subsets.
// Debian builds for the x86-64 baseline, which has no POPCNT instruction: __builtin_popcountll
// becomes a libgcc call that took 7% of a tracking run. A clone for CPUs with POPCNT is picked at
// load time (GCC function multi-versioning); other CPUs run the baseline clone.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("popcnt", "default")))
#endif
std::vector<std::pair<int, int>>
match_descriptors(const FrameFeatures& a, const std::vector<int>& subset_a, const FrameFeatures& b,
                  const std::vector<int>& subset_b, const FrontendOptions& o) {
  std::vector<std::pair<int, int>> matches;
  std::vector<int> best_for_b(b.keypoints.size(), -1), best_distance_b(b.keypoints.size(), 1 << 20);
  std::vector<std::pair<int, int>> candidates;
  for (int i : subset_a) {
    int best = -1, d1 = 1 << 20, d2 = 1 << 20;
    for (int j : subset_b) {
      const int d = hamming(a.descriptors[i], b.descriptors[j]);
      if (d < d1) {
        d2 = d1;
        d1 = d;
        best = j;
      } else if (d < d2) {
        d2 = d;
      }
    }
    if (best < 0 || d1 > o.max_hamming || d1 >= o.ratio * d2) continue;
    candidates.push_back({i, best});
    if (d1 < best_distance_b[best]) {
      best_distance_b[best] = d1;
      best_for_b[best] = i;
    }
  }
  for (const auto& m : candidates)
    if (best_for_b[m.second] == m.first) matches.push_back(m);  // one a per b
  return matches;
}

struct PairTask {
  int sensor_a, frame_a, sensor_b, frame_b;
  FramePairMatch::Kind kind;
};

// How far a cross-camera candidate got (CrossCameraFunnel).
enum class CrossStage { kNone, kBand, kMatches, kRansac, kAccepted };

struct PairOutcome {
  bool accepted = false;
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

// Step 2: the candidate frame pairs in a fixed order: each frame with the previous
// same_camera_window frames of its camera, the last loop_frames of each camera with its first
// ones, and each frame with the temporally closest frame of every other camera.
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
  if (options.cross_camera)
    for (int sa = 0; sa < sensor_count; ++sa)
      for (int sb = sa + 1; sb < sensor_count; ++sb) {
        if (!used[sa] || !used[sb] || scan.frames[sb].empty()) continue;
        const auto& frames_b = scan.frames[sb];
        for (int fa = 0; fa < int(scan.frames[sa].size()); ++fa) {
          const double t = scan.frames[sa][fa].timestamp;
          auto it = std::lower_bound(frames_b.begin(), frames_b.end(), t,
                                     [](const FrameEntry& e, double value) { return e.timestamp < value; });
          int fb = int(it - frames_b.begin());
          if (fb >= int(frames_b.size()) || (fb > 0 && t - frames_b[fb - 1].timestamp < frames_b[fb].timestamp - t))
            fb = std::max(0, fb - 1);
          tasks.push_back({sa, fa, sb, fb, FramePairMatch::Kind::kCrossCamera});
        }
      }

  return tasks;
}

// Step 3: one candidate pair matched (ratio test inside the overlap band for cross-camera pairs)
// and verified by 3D-3D RANSAC (and, across cameras, against the calibrated extrinsics).
PairOutcome match_pair(const PairTask& task, const std::vector<std::vector<FrameFeatures>>& features,
                       const ScanIndex& scan, const FrontendOptions& options) {
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
  Rigid3d predicted_a_from_b = Rigid3d::Identity();
  if (cross) {
    // The narrow overlap band: keypoints that project into the other camera (calibrated extrinsics).
    predicted_a_from_b =
        scan.rig.sensors[task.sensor_a].ref_from_cam.inverse() * scan.rig.sensors[task.sensor_b].ref_from_cam;
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
  const auto matches = match_descriptors(a, subset_a, b, subset_b, options);
  out.matches = int(matches.size());
  if (int(matches.size()) < min_inliers) return out;
  if (cross) out.cross_stage = CrossStage::kMatches;
  std::vector<Eigen::Vector3d> pa, pb;
  std::vector<double> thresholds;
  for (const auto& [i, j] : matches) {
    pa.push_back(point(a.keypoints[i], in_a));
    pb.push_back(point(b.keypoints[j], in_b));
    const double sa = point_sigma(a.keypoints[i], in_a, options), sb = point_sigma(b.keypoints[j], in_b, options);
    thresholds.push_back(std::max(options.ransac_min_threshold_m, options.ransac_sigmas * std::hypot(sa, sb)));
  }
  const std::int64_t key = (std::int64_t(task.sensor_a) * 8 + task.sensor_b) * 100000000LL +
                           std::int64_t(task.frame_a) * 10000 + (task.frame_b % 10000);
  RigidRansacResult ransac;
  const bool found = rigid_ransac(pa, pb, thresholds, options.ransac_iterations, min_inliers, options.seed, key, &ransac);
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
  out.match = {task.sensor_a, task.frame_a, task.sensor_b, task.frame_b, ransac.a_from_b, int(ransac.inliers.size()),
               task.kind};
  for (int i : ransac.inliers) out.keypoint_matches.push_back(matches[i]);
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
void reject_implausible_pairs(const std::vector<PairTask>& tasks, std::vector<PairOutcome>& outcomes,
                              const ScanIndex& scan, const FrontendOptions& options, FrontendResult& result) {
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
  std::vector<std::vector<Rigid3d>> chain_from_frame(sensor_count);
  std::vector<std::vector<int>> chain_of_frame(sensor_count);
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
    log_debug(fmt::format("{}: loop pair cam{} {}-{}: rotation {:.2f} deg from the chained transforms, translation "
                          "{:.1f} mm from the rotator's{}",
                          scan.root.string(), s, task.frame_a, task.frame_b, angle_deg, 1e3 * miss_m,
                          agrees ? "" : ": rejected"));
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
    if (kept.size() >= 2) result.landmarks.push_back(std::move(kept));
  }
}

}  // namespace

FrontendResult run_frontend(const ScanIndex& scan, const FrontendOptions& options) {
  options.check();
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
  result.features.resize(sensor_count);
  std::vector<std::pair<int, int>> frame_list;
  for (int s = 0; s < sensor_count; ++s) {
    result.features[s].resize(scan.frames[s].size());
    if (used[s])
      for (int f = 0; f < int(scan.frames[s].size()); ++f) frame_list.push_back({s, f});
  }

  // 1. Features (one task per frame).
  tbb::parallel_for(std::size_t(0), frame_list.size(), [&](std::size_t k) {
    const auto [s, f] = frame_list[k];
    const RgbdFrame frame = load_frame(scan, s, std::size_t(f));
    result.features[s][f] = extract_features(frame, scan.rig.sensors[s].intrinsics, options);
  });
  const auto features_done = std::chrono::steady_clock::now();
  for (const auto& [s, f] : frame_list)
    if (int(result.features[s][f].keypoints.size()) < options.min_inliers) ++result.frames_without_features;

  // 2. Candidate pairs in a fixed order; 3. matched and verified (one task per pair); 4. landmarks.
  const std::vector<PairTask> tasks = candidate_pairs(scan, used, options);
  std::vector<PairOutcome> outcomes(tasks.size());
  tbb::parallel_for(std::size_t(0), tasks.size(),
                    [&](std::size_t k) { outcomes[k] = match_pair(tasks[k], result.features, scan, options); });
  for (std::size_t k = 0; k < tasks.size(); ++k) {
    if (tasks[k].kind != FramePairMatch::Kind::kCrossCamera) continue;
    const PairOutcome& out = outcomes[k];
    CrossCameraFunnel& funnel = result.cross_camera;
    ++funnel.candidates;
    funnel.with_band_keypoints += out.cross_stage >= CrossStage::kBand;
    funnel.with_matches += out.cross_stage >= CrossStage::kMatches;
    funnel.with_ransac += out.cross_stage >= CrossStage::kRansac;
    funnel.accepted += out.cross_stage >= CrossStage::kAccepted;
    funnel.band_keypoints_a += out.band_keypoints_a;
    funnel.band_keypoints_b += out.band_keypoints_b;
    funnel.matches += out.matches;
    funnel.inliers += out.inliers;
  }
  reject_implausible_pairs(tasks, outcomes, scan, options, result);
  build_landmarks(outcomes, result);
  const auto done = std::chrono::steady_clock::now();
  const double frames = std::max<std::size_t>(1, frame_list.size());
  result.feature_ms_per_frame = std::chrono::duration<double, std::milli>(features_done - start).count() / frames;
  result.matching_ms_per_frame = std::chrono::duration<double, std::milli>(done - features_done).count() / frames;
  result.total_seconds = seconds_between(start, done);
  return result;
}

}  // namespace panoscan
