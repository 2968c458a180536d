// Front end of the joint tracking (paper §4.1, "Correspondences between frames and landmarks"):
// ORB keypoints with depth from the registered depth image, matches between frames of one camera
// verified by 3D-3D RANSAC, matches across cameras between temporally closest frames inside their
// narrow overlap band (ORB, and band alignment by small patches: src/cross_camera.h), loop closure at the end of the turn, and landmarks as tracks of matches
// (union-find over matched keypoints).
//
// Loop closure: instead of randomised ferns (Glocker et al. 2015) the last `loop_frames` frames
// of each camera are matched against its first `loop_frames` frames (ORB + the same RANSAC). A
// panoramic scan ends where it started, so this is the place recognition the method needs.
// A room with repeated objects (two identical desks side by side) gives loop pairs that RANSAC
// verifies but that map one object onto its twin, metres away; a few of them bend the whole
// trajectory (generated office seed 3: the middle camera's circle shrank from 105 to 82 mm, ATE
// 26 mm). So each loop pair must also fit the motion of an in-place rotator: its rotation agrees
// with the camera's chained frame-to-frame rotations, and its translation with the one the rotation
// implies about the camera's axis (loop_max_deviation_*, max_pair_translation_m; frontend.cpp,
// reject_implausible_pairs; recon/tracking/README.md, "False loop closures").
//
// Determinism: RANSAC draws come from RandomStream keyed by (seed, camera, frame, pair), and all
// parallel work writes to per-frame / per-pair slots merged in a fixed order, so the result does
// not depend on the thread count.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/core/rigid_ransac.h"
#include "panoscan/core/scan.h"
#include "panoscan/recon/depth_grid.h"

namespace panoscan {

struct FrontendOptions {
  int orb_features = 1000;        // ORB keypoints per 640x480 frame (scaled with the image area)
  double orb_scale_factor = 1.2;  // pyramid scale (sigma_u,v = scale^octave px in Eq. 1)
  // Pyramid levels (frontend.orb_levels); 0 = by the scan's motion (orb_levels_for): on a rotator the
  // camera stays within ~10 cm of one point and sees nothing change scale between its frames, and the
  // coarse levels only displace fine keypoints from ORB's per-level quota (recon/tracking/README.md,
  // "ORB pyramid levels": 3 levels gave a lower ATE than 8 in 16 of 20 scans and a 15% cheaper
  // detection); a handheld recording keeps ORB-SLAM2's 8 for its changes of scale.
  int orb_levels = 0;
  int orb_fast_threshold = 12;
  // Keypoints are detected at least this far from the image border (0 = min(31, width / 20), ORB's
  // usual border: the 31-px descriptor patch fits inside the image). Smaller values keep keypoints
  // up to the border, their descriptors computed on ORB's reflected padding.
  int orb_border_px = 0;  // frontend.orb_border_px
  int max_hamming = 64;             // descriptor distance limit
  double ratio = 0.8;               // Lowe ratio test
  int same_camera_window = 2;       // frame i is matched with i-1 ... i-window of its camera
  // Same-camera and loop pairs matched by projection (frontend.cpp, match_by_projection):
  // guide_keypoints of frame a (per 640x480 frame, scaled with the image area), spread over its
  // list, matched against all of b and verified by RANSAC predict a_from_b; each keypoint of a is
  // then compared only with b's keypoints within guided_radius_px (at 640 px width, scaled with the
  // width) of its predicted position. A pair whose sample does not verify falls back to matching
  // every keypoint with every one. Off: every pair brute force.
  bool guided_matching = true;   // frontend.guided_matching
  int guide_keypoints = 150;     // frontend.guide_keypoints
  double guided_radius_px = 10;  // frontend.guided_radius_px
  bool cross_camera = true;         // ORB matches between cameras (temporally closest frames)
  int cross_overlap_margin_px = 8;  // a keypoint is in the overlap band if it projects this far inside the other image
  // Band alignment across cameras (frontend.band_*; src/cross_camera.h): the narrow overlap matched
  // by small patches warped with the predicted transform and aligned by normalised cross-correlation.
  bool band_matching = true;       // frontend.band_matching
  int band_patch_long_px = 21;     // frontend.band_patch_long_px: patch length along the band
  int band_patch_short_px = 3;     // frontend.band_patch_short_px: and across it (the band: 4-8 px)
  double band_search_deg = 1.2;    // frontend.band_search_deg: calibration error the first search covers
  int band_refine_px = 4;          // frontend.band_refine_px: per-pair search around the corrected prediction
  double band_min_ncc = 0.85;      // frontend.band_min_ncc: correlation floor of an aligned patch
  double band_min_contrast = 3.0;  // frontend.band_min_contrast: grey-level std of a usable patch
  double band_min_gradient = 1.5;  // frontend.band_min_gradient: grey levels / px in its weaker direction
  double band_peak_ratio = 1.5;    // frontend.band_peak_ratio: votes for the correction vs any 3 px away
  double band_peak_margin = 0.05;  // frontend.band_peak_margin: a patch's peak correlation vs its best 3 px away
  double band_max_shift_spread_px = 1.5;  // frontend.band_max_shift_spread_px: from the pair's median shift
  double band_depth_slack_m = 0.02;  // frontend.band_depth_slack_m: beyond 3 sigma of the depth noise
  int band_frames = 5;               // frontend.band_frames: frames of the other camera nearest in time
  int band_calibration_pairs = 256;  // frontend.band_calibration_pairs: frames of a sampled for the first search
  int band_max_corners = 1500;       // corners kept per crop (strongest first)
  bool loop_closure = true;
  int loop_frames = 4;  // last k frames vs first k frames of each camera
  // A loop pair is kept only if its rotation is within loop_max_deviation_deg of the chained
  // same-camera rotations (their drift over one revolution: 2-4 deg measured) and its translation
  // within loop_max_deviation_m of (I - R) p, the rotator's motion about the camera's fitted axis
  // point p (0 = that check off; no chain joining the two frames = no rotation check).
  double loop_max_deviation_deg = 10.0;  // frontend.loop_max_deviation_deg
  double loop_max_deviation_m = 0.15;    // frontend.loop_max_deviation_m
  // Two poses of one camera on an in-place rotator are at most twice its distance from the axis
  // apart; pairs (same camera or loop) whose RANSAC transform moves the camera farther are false.
  double max_pair_translation_m = 0.5;  // frontend.max_pair_translation_m
  // RANSAC's draws per pair: at most ransac_iterations, stopping once an all-inlier sample would
  // have been drawn with probability ransac_confidence given the best consensus so far (1 = every
  // draw), after at least ransac_min_iterations. Consecutive frames agree on 70-95% of their matches,
  // where 10-30 draws reach 0.9999: the fixed 200 were 6% of the front end's instructions.
  int ransac_iterations = 200;         // frontend.ransac_iterations
  double ransac_confidence = 0.9999;   // frontend.ransac_confidence
  int ransac_min_iterations = 20;      // frontend.ransac_min_iterations
  double ransac_sigmas = 3.0;  // inlier threshold: this many std of the 3D point difference
  double ransac_min_threshold_m = 0.005;
  int min_inliers = 12;                  // same camera and loop closure
  int min_cross_inliers = 6;             // across cameras (narrow band)
  double cross_max_deviation_deg = 3.0;  // cross-camera transform vs calibrated extrinsics
  double cross_max_deviation_m = 0.10;
  double min_depth_m = 0.3, max_depth_m = 8.0;
  double depth_noise_coefficient = 9.49e-4;  // sigma_Z = c * Z^2 (ARCHITECTURE.md §4.1, Handa et al. 2014)
  std::uint64_t seed = 1;
  int threads = 0;           // 0 = all cores
  std::vector<int> sensors;  // sensors to use (empty = all)
  // Block size of the depth grid kept per frame for the tracking's depth odometry (depth_grid.h);
  // 0 = none. Not a config key of its own: track.depth_odometry sets it.
  int depth_grid_block = 0;

  void check(const std::string& origin = "<frontend options>") const;
};

struct Keypoint {
  float u = 0, v = 0;  // pixel (OpenCV convention)
  float depth = 0;     // metres, z along the optical axis
  int octave = 0;
};

struct FrameFeatures {
  double timestamp = 0.0;
  std::vector<Keypoint> keypoints;  // only keypoints with valid depth
  std::vector<std::array<std::uint8_t, 32>> descriptors;
};

struct Observation {
  int sensor = 0;
  int frame = 0;
  int keypoint = 0;
};

// A verified relative transform between two frames: point_in_a = a_from_b * point_in_b.
struct FramePairMatch {
  int sensor_a = 0, frame_a = 0, sensor_b = 0, frame_b = 0;
  Rigid3d a_from_b = Rigid3d::Identity();
  int inliers = 0;
  enum class Kind { kSameCamera, kCrossCamera, kLoop } kind = Kind::kSameCamera;
  // The correspondences the transform rests on (RANSAC's inliers; a band pair's matches): a's and b's
  // back-projected keypoints in their cameras' frames, and each correspondence's inlier threshold in
  // metres (its 3-D difference's std times frontend.ransac_sigmas, as RANSAC used it). The tracking's
  // self-check holds a trajectory against these rather than against a_from_b, which few or far
  // features leave uncertain by degrees (recon/tracking/README.md, "The self-check").
  std::vector<Eigen::Vector3d> points_a, points_b;
  std::vector<double> thresholds;
};

// Where cross-camera candidate pairs are lost, step by step (the diagnosis of the narrow overlap:
// recon/tracking/README.md, "Cross-camera matching"). Each count is of candidate pairs that got
// that far; the keypoint and match sums are over all candidate pairs.
struct CrossCameraFunnel {
  int candidates = 0;           // temporally closest frame pairs of neighbouring cameras
  int with_band_keypoints = 0;  // both frames have >= min_cross_inliers keypoints in the predicted band
  int with_matches = 0;         // >= min_cross_inliers descriptor matches (ratio test) inside the band
  int with_ransac = 0;          // 3D-3D RANSAC found >= min_cross_inliers inliers
  int accepted = 0;             // and the transform agrees with the calibrated extrinsics
  long long band_keypoints_a = 0, band_keypoints_b = 0;  // keypoints in the band, summed
  long long matches = 0, inliers = 0;                    // descriptor matches and RANSAC inliers, summed
  int unpredicted = 0;  // no chain covered both shutter times (the pair was not tried)
  // Band alignment (src/cross_camera.h): frame pairs tried, with enough corners of a predicted
  // inside b, and accepted; corners, aligned patches and matches summed.
  int band_candidates = 0, band_unpredicted = 0, band_with_anchors = 0, band_accepted = 0;
  long long band_anchors = 0, band_aligned = 0, band_matches = 0;
  // Per overlapping camera pair: the calibration's rotation error the band's first search found, and
  // how many patch votes agreed on it (too few or ambiguous: none applied).
  struct BandRelation {
    int sensor_a = 0, sensor_b = 0, votes = 0;
    double correction_deg = 0;
  };
  std::vector<BandRelation> band_relations;
};

struct FrontendResult {
  std::vector<std::vector<FrameFeatures>> features;  // per sensor, per frame of the scan
  std::vector<FramePairMatch> pairs;                 // accepted pairs, in a fixed order
  std::vector<std::vector<Observation>> landmarks;   // tracks: at most one observation per frame, >= 2 frames
  int same_camera_pairs = 0, cross_camera_pairs = 0, loop_pairs = 0;
  int rejected_loop_pairs = 0;  // RANSAC-verified loop pairs that disagree with the chained transforms
  int rejected_far_pairs = 0;   // verified same-camera or loop pairs beyond max_pair_translation_m
  CrossCameraFunnel cross_camera;
  // Per sensor: landmarks it shares with another camera, and its observations of them.
  std::vector<int> cross_landmarks, cross_observations;
  int frames_without_features = 0;  // fewer than min_inliers keypoints with depth
  // Same-camera and loop pairs matched by projection, and those whose sample did not verify
  // (matched brute force).
  int guided_pairs = 0, guided_fallbacks = 0;
  // Per sensor, per frame: the depth grid (FrontendOptions::depth_grid_block; empty when 0).
  std::vector<std::vector<DepthGrid>> depth_grids;
  int orb_levels = 0;               // the pyramid levels used (orb_levels_for)
  double feature_ms_per_frame = 0;  // extraction (wall time / frames)
  double matching_ms_per_frame = 0;
  double total_seconds = 0;
};

// The pyramid levels the front end uses for a scan of this motion: options.orb_levels, or where it is
// 0, kRotatorOrbLevels on a rotator and kHandheldOrbLevels for a handheld recording.
constexpr int kRotatorOrbLevels = 3, kHandheldOrbLevels = 8;
int orb_levels_for(const FrontendOptions& options, RigMotion motion);

// Runs the whole front end on a scan (reads the frames). Throws Error on unreadable frames.
FrontendResult run_frontend(const ScanIndex& scan, const FrontendOptions& options);

// Frame pairs are verified with core's rigid_ransac (panoscan/core/rigid_ransac.h).

}  // namespace panoscan
