// Joint tracking of the unsynchronized cameras (paper §4.1): a factor graph solved with Ceres.
//
// Variables: landmarks y_j; per frame (camera c, frame i) the pose T_ci (world_from_cam, world =
// the first frame of the reference camera, held fixed) and the azimuth alpha_ci; the axis pose T_u
// (world_from_axis); the extrinsics T_c (ref_from_cam) of the non-reference cameras.
// Factors:
//   Eq. 1 observation: p = d [u, v, 1] against K (T_ci^-1 y_j), covariance of p propagated from
//          diag(sigma_u^2, sigma_v^2, sigma_d^2) (sigma_u,v = 1.2^octave px, sigma_d = 9.49e-4 d^2 m,
//          docs/ARCHITECTURE.md §4.1), Huber kernel;
//   Eq. 2 pose regularisation: log(T_ci^-1 T_u R(alpha_ci) T_u^-1 T_r T_c) with 5 mm / 0.5 deg std;
//   Eq. 3 velocity smoothness over all frames of all cameras in timestamp order.
// Choices (documented in tracking.cpp): rotations as unit quaternions on Ceres' QuaternionManifold
// (not Euler angles); alpha unwrapped (a real number, so the wrap-around subtraction of Eq. 3 is a
// plain difference, and the output is wrapped to [0, 2 pi)); the residual of Eq. 2 is
// (translation, rotation vector) of the error transform; the two gauge freedoms of T_u (rotation
// about and translation along its own axis, which cancel in T_u R T_u^-1) are fixed by a weak prior
// (1 m, 1 rad) and the output uses the gauge of rig_trajectory.h (axis_frame()).
// The rig pose T_r (world_from_rig, a deviation from the paper): the reference camera's pose at
// alpha = 0 without wobble. The paper's Eq. 2 has T_r = I with the first reference frame fixed as
// the world, which makes that frame's own wobble (0.5 deg per axis) an extrinsic error of the
// reference camera that nothing can absorb, and the fit tilts the axis to compromise. T_r is free
// (6 DoF); its rotation about the axis trades with a shift of every azimuth, so the first reference
// azimuth is held instead.
// Two more factors beyond the paper (TrackingOptions::shared_wobble, extrinsics_null_prior): the
// wobble is the bracket's, so frames of different cameras a few ms apart share it; and T_c is held
// at the calibration along the two directions nothing observes without cross-camera landmarks (its
// rotation about and slide along the axis). Measurements for T_r and both factors:
// recon/tracking/README.md.
// Initialisation: the reference camera's frame-to-frame RANSAC transforms are chained; an axis is
// fitted to those poses (direction: mean rotation vector, point: least-squares fixed point of the
// rotations); alpha_ci is the reference rotation about that axis, interpolated in time for the
// other cameras, whose poses start at T_u R(alpha) T_u^-1 T_c with the calibrated T_c.
// Handheld recordings (rig.json "motion": handheld, e.g. `import tum`): no rotator, so no Eq. 2-3
// and no axis. Only ba-only and single-camera run (both Eq. 1 alone; full and fixed-extrinsics are
// refused), the other cameras start at (and in single-camera mode stay at) the reference camera's
// pose interpolated to their timestamps times the calibrated T_c, the front end skips the
// end-of-turn loop closure, and verify_tracking leaves out the rotator's checks.
// Determinism: for a given seed and thread count (Ceres' parallel Jacobian evaluation sums in a
// fixed order; the front end is thread-count independent).
#pragma once

#include <array>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "panoscan/core/scan.h"
#include "panoscan/recon/frontend.h"
#include "panoscan/recon/rig_trajectory.h"

namespace panoscan {
class Config;

enum class TrackingMode {
  kFull,             // Eq. 1-3, all cameras, extrinsics refined
  kBaOnly,           // Eq. 1 alone (paper Table 2 "BA only")
  kSingleCamera,     // the reference (middle) camera alone, Eq. 1-3 (Table 2); the others follow the model
  kFixedExtrinsics,  // Eq. 1-3 with the calibrated extrinsics held fixed
};

// The self-check of a tracked trajectory (verify_tracking). Keys track.verify.*. Every limit is a
// physical bound of the set-up (one revolution in one direction on a rotator whose axis is near
// the cameras' up), not a figure of a particular scan.
struct TrackingVerifyOptions {
  bool enabled = true;             // track.verify.enabled: false = no checks, always "reliable"
  int min_frame_observations = 6;  // track.verify.min_frame_observations: a frame with fewer is unsupported
  double max_unsupported_turn_deg =
      45;                     // track.verify.max_unsupported_turn_deg: longest turn no camera supports (1/8 rev.)
  double min_turn_deg = 340;  // track.verify.min_turn_deg: the scan must cover one revolution ...
  double max_turn_deg = 380;  // track.verify.max_turn_deg: ... and not much more
  double max_backward_step_deg = 2.0;  // track.verify.max_backward_step_deg: azimuth steps against the turn
  // track.verify.min_pair_inlier_share: a verified frame pair agrees with the trajectory when the
  // tracked relative pose keeps at least this share of the pair's RANSAC inliers within their
  // thresholds (a majority: over 49 right trajectories 12 of 12574 pairs, false matches, kept fewer;
  // recon/tracking/README.md, "The self-check").
  double min_pair_inlier_share = 0.5;
  double min_consistent_pair_share = 0.8;  // track.verify.min_consistent_pair_share (same-camera pairs)
  // track.verify.min_consistent_loop_share: lower than for same-camera pairs, since a repetitive room
  // gives RANSAC-verified false loop matches, while a wrong trajectory disagrees with nearly all.
  double min_consistent_loop_share = 0.5;
  double max_outlier_share = 0.2;          // track.verify.max_outlier_share: whitened residual > 3 huber_delta
  double max_extrinsics_change_deg = 3.0;  // track.verify.max_extrinsics_change_deg: T_c vs the calibration
  double max_extrinsics_change_m = 0.03;   // track.verify.max_extrinsics_change_m
  double max_axis_tilt_deg = 30.0;         // track.verify.max_axis_tilt_deg: axis vs the reference camera's up (-y)
  // track.verify.max_unsupported_s: handheld recordings (no turn to measure a gap by): the longest
  // time no camera supports, over which the poses are extrapolated from the last motion.
  double max_unsupported_s = 1.0;
  // track.verify.max_depth_yaw_std_deg (rotator): a frame also counts as supported when a
  // depth-odometry pair it is in measures the turn about the rig's axis to this standard deviation
  // (from the pair's information, TrackingResult::depth_yaw_std_deg) and the solution agrees with
  // the pair (its whitened residual within the factor's Huber threshold, kDepthOdometryHuber): the
  // depth of a plain wall carries the azimuth as landmarks do. 0: only landmarks support. How 0.1
  // was chosen: recon/tracking/README.md, "The self-check".
  double max_depth_yaw_std_deg = 0.1;
  // track.verify.max_model_departure_sigma (rotator, Eq. 2 in the graph): no frame may depart from
  // the rotator model by more than this many of Eq. 2's standard deviations (the whitened norm of
  // its error transform, reg_translation_std_m / reg_rotation_std_deg): the rig's wobble cannot put
  // a camera there, so the solution is wrong at that frame or the rig is not what rig.json says.
  // Over 48 right trajectories of 12 rooms the largest was 5.1 (the simulator's own wobble reaches
  // 4.4 at one instant); a depth pair that slid 4 cm put a frame at 8.8 (recon/tracking/README.md,
  // "The self-check").
  double max_model_departure_sigma = 6.0;

  void check(const std::string& origin) const;
};

struct TrackingOptions {
  TrackingMode mode = TrackingMode::kFull;  // track.mode: full | ba-only | single-camera | fixed-extrinsics
  bool pose_regularisation = true;          // track.pose_regularisation: Eq. 2 on/off (ablation)
  bool velocity_smoothness = true;          // track.velocity_smoothness: Eq. 3 on/off (ablation)
  double reg_translation_std_m = 0.005;     // track.reg_translation_std_m (paper §6.1)
  double reg_rotation_std_deg = 0.5;        // track.reg_rotation_std_deg (paper §6.1)
  // Eq. 3's confidence as an angular-acceleration std (docs/ARCHITECTURE.md §8.2; paper: variance "1/s^2").
  double angular_accel_std_deg_s2 = 1.0;  // track.angular_accel_std_deg_s2
  // true: the std of v_{i,i+1} - v_{i-1,i} is accel_std * (t_{i+1} - t_{i-1}) / 2 (the velocity change a
  // random acceleration causes over the interval); false: accel_std * 1 s, the paper's constant Omega_vel.
  bool velocity_std_scales_with_dt = true;  // track.velocity_std_scales_with_dt
  // The calibrated extrinsics as a prior on T_c (the calibration's accuracy). Needed: with the narrow
  // overlap band few or no cross-camera landmarks exist, and Eq. 2 leaves each T_c free to rotate about
  // and slide along the axis; the prior holds those two directions at the calibration.
  double extrinsics_prior_translation_std_m = 0.01;  // track.extrinsics_prior_translation_std_m
  double extrinsics_prior_rotation_std_deg = 1.0;    // track.extrinsics_prior_rotation_std_deg
  // Holds T_c at the calibration (0.1 mm, 0.01 deg) along its two unobserved directions (rotation
  // about and sliding along the axis), where only weak second-order forces act.
  bool extrinsics_null_prior = true;  // track.extrinsics_null_prior
  // ... released for a camera whose T_c the data observe: it shares at least this many landmarks
  // with the reference camera, or with a camera that does (cross-camera band matches, frontend.h).
  int extrinsics_release_min_landmarks = 20;  // track.extrinsics_release_min_landmarks
  // Where released, the slide along the axis stays held anyway (only the rotation about the axis is
  // released). track_with_frontend sets it for a second solve when the first moved the extrinsics
  // further from the calibration than the self-check allows: a narrow band's landmarks lie at
  // similar depths, so a slide can trade against a tilt (recon/tracking/README.md).
  bool hold_extrinsics_slide = false;  // track.hold_extrinsics_slide
  // Shared wobble (beyond the paper; SharedWobbleCost in tracking_factors.h): consecutive frames of
  // different cameras dt apart share the rig's wobble up to its change over dt, std = rate * dt (+ a
  // floor for timestamp jitter); linked only while rate * dt is below Eq. 2's std (beyond that the
  // two deviations are as good as independent). The rates are the std of the wobble's rate of
  // change (how the defaults follow from the paper's wobble: recon/tracking/README.md).
  bool shared_wobble = true;           // track.shared_wobble
  double wobble_rate_std_deg_s = 8.0;  // track.wobble_rate_std_deg_s
  double wobble_rate_std_m_s = 0.08;   // track.wobble_rate_std_m_s
  double same_time_s = 1e-3;           // track.same_time_s: frames closer in time share one azimuth
  // Depth odometry (beyond the paper; recon/tracking/src/depth_odometry.h): point-to-plane ICP between
  // consecutive frames of each camera as a relative-pose factor weighted by the ICP's information,
  // so that frames that see only a plain wall or ceiling are held by their depth as well as by
  // Eq. 2-3. Not in ba-only mode (Eq. 1 alone). On by default, like the shared wobble: it lowers the
  // ATE 1.3-4.5x on every scan tried, where Eq. 1-3 alone beat bundle adjustment by only 1.24-1.28x
  // (Table 2). false = the paper's graph, which the table drivers pin. recon/tracking/README.md.
  bool depth_odometry = true;                     // track.depth_odometry
  int depth_odometry_block_px = 4;                // track.depth_odometry_block_px: pixels per grid sample side
  double depth_odometry_information_scale = 1.0;  // track.depth_odometry_information_scale
  double depth_odometry_max_distance_m = 0.10;    // track.depth_odometry_max_distance_m: first pairing gate
  double depth_odometry_min_overlap = 0.25;       // track.depth_odometry_min_overlap: inliers / samples
  double huber_delta = 2.796;                     // track.huber_delta: on the whitened residual (sqrt of chi2(3) 95%)
  double depth_noise_coefficient = 9.49e-4;  // track.depth_noise_coefficient: sigma_d = c d^2, ARCHITECTURE.md §4.1
  int max_iterations = 100;                  // track.max_iterations
  // track.function_tolerance: stop when an iteration lowers the cost by less than this fraction
  // (why 1e-4: recon/tracking/README.md, "Solver tolerance").
  double function_tolerance = 1e-4;
  // track.initial_trust_region_radius: Levenberg-Marquardt's first radius; its damping is 1 / radius on the
  // Jacobi-scaled normal equations. 0 (the default) = automatic: 1e8 when the graph has Eq. 2's factors,
  // Ceres' 1e4 otherwise. With Eq. 2-3 the front end's chains start close to the solution, and 1e4 damped
  // the weakly constrained directions (azimuths, wobble) for the first iterations while the radius tripled
  // each step; 1e8 (nearly Gauss-Newton, still shrunk on a rejected step) halves the iterations at the
  // same accuracy. Bundle adjustment alone (ba-only, handheld) is ill-conditioned along its weak directions,
  // where strong first damping keeps it near the chains, so it keeps 1e4 (recon/tracking/README.md,
  // "Solver speed").
  double initial_trust_region_radius = 0.0;
  bool log_iterations = false;  // track.log_iterations: one log line per LM iteration (cost, times)
  // track.linear_solver: sparse_schur | dense_schur | iterative_schur | sparse_normal_cholesky
  std::string linear_solver = "sparse_schur";
  // track.schur_ordering: which blocks the Schur solvers eliminate. "landmarks": exactly the
  // landmarks, the other blocks in the graph's order (frames in time order, then T_c, T_u, T_r);
  // "automatic": Ceres' own independent set (recon/tracking/README.md, "Solver speed").
  std::string schur_ordering = "landmarks";
  int threads = 0;  // threads (0 = all cores)
  // track.solver_threads: Ceres' threads for the solve (0 = `threads`). One by default: Ceres'
  // multi-threaded reductions reorder floating-point sums, so runs with the same thread count
  // differed in the last bits; with one the trajectory is bit for bit the same for any `threads`,
  // and on 2 cores the solve was faster too (recon/tracking/README.md, "Solver speed").
  int solver_threads = 1;
  FrontendOptions frontend;      // frontend.* keys
  TrackingVerifyOptions verify;  // track.verify.* keys
  // track.allow_unreliable: require_reliable_tracking warns instead of refusing (for inspection).
  bool allow_unreliable = false;

  void check(const std::string& origin = "<tracking options>") const;
};

struct TrackingStats {
  std::string mode;
  int frames = 0, landmarks = 0, observations = 0;
  int frames_without_observations = 0;  // kept, with only Eq. 2-3 (held at their initial pose in ba-only)
  int residual_blocks = 0, parameters = 0;
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;
  // The cost of each term (Ceres' 1/2 sum of squares, Huber applied): observation (Eq. 1),
  // regularisation (Eq. 2), velocity (Eq. 3), the priors on T_u and T_c, the shared wobble, the depth odometry.
  std::array<double, 6> initial_term_costs{}, final_term_costs{};
  // Depth odometry: consecutive frame pairs aligned and used as factors, and those left out.
  int depth_pairs = 0, depth_pairs_rejected = 0;
  int depth_icp_iterations = 0;  // Gauss-Newton iterations summed over all aligned pairs
  double depth_odometry_seconds = 0;
  int shared_wobble_links = 0;
  bool converged = false;   // Ceres reported CONVERGENCE and every pose is finite
  std::string termination;  // Ceres' message
  std::string linear_solver;
  int threads = 1;
  double frontend_seconds = 0, feature_ms_per_frame = 0, matching_ms_per_frame = 0;
  int orb_levels = 0;  // the ORB pyramid levels the front end used (orb_levels_for)
  double init_seconds = 0, solve_seconds = 0;
  double linear_solver_seconds = 0, jacobian_seconds = 0;  // parts of solve_seconds (Ceres' summary)
  int same_camera_pairs = 0, cross_camera_pairs = 0, loop_pairs = 0, frames_without_features = 0;
  int guided_pairs = 0, guided_fallbacks = 0;            // pairs matched by projection / brute force (frontend.h)
  int rejected_loop_pairs = 0, rejected_far_pairs = 0;   // FrontendResult's, for tracking_stats.json
  CrossCameraFunnel cross_camera;                        // FrontendResult's: where cross-camera pairs are lost
  std::vector<int> cross_landmarks, cross_observations;  // per sensor (FrontendResult's)
  std::vector<char> extrinsics_observed;  // per sensor: null-space prior released (extrinsics_release_min_landmarks)
  // The kept solve held the slide along the axis (hold_extrinsics_slide), set or as the retry after
  // a released solve failed the self-check's extrinsics test (that failure: first_solve_failure).
  bool extrinsics_slide_held = false;
  std::string first_solve_failure;
};

// One check of verify_tracking: its figure against its limit.
struct TrackingCheck {
  // frames, turn, monotone, model, pairs, loop, residuals, extrinsics, axis, finite (handheld: no turn,
  // monotone, model, axis)
  std::string name;
  bool passed = true;
  double value = 0.0, limit = 0.0;
  std::string detail;  // one line: what was measured and why it matters
};

// Per frame of each camera: its support by the data.
struct FrameSupport {
  int observations = 0;  // Eq. 1 observations (0 for cameras not in the graph)
  // The best (smallest) turn std of the depth-odometry pairs the frame is in (deg; +inf: none).
  double depth_yaw_std_deg = std::numeric_limits<double>::infinity();
  bool depth_supported = false;  // depth_yaw_std_deg <= max_depth_yaw_std_deg (rotator)
  // The whitened residual at the solution of the depth-odometry pair (f, f + 1) (+inf: none).
  double depth_residual = std::numeric_limits<double>::infinity();
  // Its departure from the rotator model (Eq. 2's error transform; 0 without Eq. 2).
  double model_departure_mm = 0.0, model_departure_deg = 0.0;
  double gap_deg = 0.0;  // turn from this frame to the nearest instant some camera supports (rotator; else 0)
  double gap_s = 0.0;    // the same in seconds
  // max(min(1, observations / min_frame_observations), 1 if depth_supported) * max(0, 1 - gap / max
  // gap), the gap in degrees (rotator: max_unsupported_turn_deg) or seconds (handheld: max_unsupported_s)
  double confidence = 0.0;
};

struct TrackingVerdict {
  bool checked = false;  // false: verification disabled
  bool reliable = true;
  std::vector<TrackingCheck> checks;
  std::vector<std::vector<FrameSupport>> frames;  // per sensor, per frame
  // "check: detail" of the first failed check ("" when reliable).
  std::string first_failure() const;
};

struct TrackingResult {
  RigTrajectory trajectory;                                // every frame of the scan, source "tracked:<mode>"
  std::vector<std::vector<double>> azimuth_rad;            // per sensor, per frame, in [0, 2 pi)
  std::vector<std::vector<double>> azimuth_unwrapped_rad;  // the same, unwrapped (continuous)
  // Per sensor, per frame f: the standard deviation (deg) of the turn about the rig's axis that the
  // depth-odometry pair of frames f and f + 1 measured, from its information with every other
  // direction free; +inf where there is no pair (rejected, the last frame, depth odometry off).
  std::vector<std::vector<double>> depth_yaw_std_deg;
  // Per sensor, per frame f: the whitened norm of that pair's factor at the solution (its 6-vector
  // residual times the square root of the pair's information, no Huber loss); +inf where there is
  // no pair. About sqrt(6) where the solution and the pair agree within the pair's claimed noise.
  std::vector<std::vector<double>> depth_pair_residual;
  // Per sensor, per frame: the frame's departure from the rotator model at the solution (Eq. 2's
  // error transform: translation in mm, rotation in deg; empty without Eq. 2).
  std::vector<std::vector<double>> model_departure_mm, model_departure_deg;
  TrackingStats stats;
  TrackingVerdict verdict;
};

// The Huber threshold of the depth-odometry factor on its whitened 6-vector (sqrt of chi2(6) 95%):
// within it the solve takes a pair as it is; beyond it, as a likely outlier.
inline constexpr double kDepthOdometryHuber = 3.548;

// Checks a solution against what a rotator scan must satisfy and what the front end measured
// independently of the graph (paper §4.1 leaves this to the user; a testbed cannot):
//  - frames: no stretch of more than max_unsupported_turn_deg where no camera has
//    min_frame_observations observations or a depth-odometry pair that measures the turn
//    (max_depth_yaw_std_deg) and agrees with the solution: there Eq. 2-3 alone extrapolate the azimuth;
//  - model: no frame departs from the rotator model by more than max_model_departure_sigma (Eq. 2);
//  - turn: the reference camera turns one revolution (min/max_turn_deg);
//  - monotone: its azimuth never steps back by more than max_backward_step_deg;
//  - pairs, loop: the tracked relative poses of the front end's verified frame pairs (same camera;
//    loop closure) keep min_pair_inlier_share of each pair's RANSAC inliers, for at least
//    min_consistent_pair_share of the same-camera pairs (pooled and per camera) and
//    min_consistent_loop_share of the loop pairs;
//  - residuals: at most max_outlier_share of the observations are gross outliers;
//  - extrinsics: each estimated T_c within max_extrinsics_change_* of the calibration (rig.json);
//  - axis: the rotation axis within max_axis_tilt_deg of the reference camera's up;
//  - finite: every pose finite.
// A handheld recording (rig.motion) is checked for frames (in seconds: max_unsupported_s), pairs,
// loop, residuals, extrinsics and finite; turn, monotone and axis are rotator properties.
// `observations`: per sensor, per frame, the Eq. 1 observations in the graph (empty for sensors
// outside it); `residual_norms`: the whitened norm of every observation residual.
TrackingVerdict verify_tracking(const TrackingResult& result, const ScanIndex& scan, const FrontendResult& frontend,
                                const std::vector<std::vector<int>>& observations,
                                const std::vector<double>& residual_norms, const TrackingOptions& options);

// Throws Error "<scan_name>: tracking: not trustworthy: <first failed check>" when the verdict is
// unreliable (the stage refuses: exit code 2 in the program), unless options.allow_unreliable,
// which logs a warning instead. Every stage that consumes tracked poses calls it.
void require_reliable_tracking(const TrackingResult& result, const TrackingOptions& options,
                               const std::string& scan_name);

// The one-call entry: front end + factor graph. Throws Error for unusable input (no reference
// frames, a reference camera without any verified frame pair); reports non-convergence in stats.
TrackingResult track_scan(const ScanIndex& scan, const TrackingOptions& options);
// The factor graph on a front end that already ran (tests and ablations reuse one front end). In
// single-camera mode only the reference camera's features and pairs are used.
// initial_guess (optional): start from these poses, axis and extrinsics instead of the
// initialisation above (any world frame; experiments start from the ground truth to separate the
// optimum of the graph from the convergence to it).
TrackingResult track_with_frontend(const ScanIndex& scan, const FrontendResult& frontend,
                                   const TrackingOptions& options, const RigTrajectory* initial_guess = nullptr);

TrackingOptions tracking_options_from_config(Config& config);
const char* to_string(TrackingMode mode);
TrackingMode tracking_mode_from_string(const std::string& text, const std::string& origin);

// Writes the rig trajectory (write_rig_trajectory) plus tracking_stats.json (with the verdict, the
// per-frame support and "written_by": version and source revision), atomically. An unreliable
// result is written with its trajectory's source marked ":unreliable". `scan_dir`, when given, is
// recorded as "scan" (absolute), so that a reader (the HTML report) can find the ground truth.
void write_tracking_result(const std::filesystem::path& dir, const TrackingResult& result, const RigInfo& rig,
                           const std::filesystem::path& scan_dir = {});
std::string tracking_stats_json(const TrackingStats& stats);
// The stats plus "verdict" (every check) and "frame_support" (per camera: observations, gap_deg, confidence).
std::string tracking_stats_json(const TrackingResult& result, const RigInfo& rig);

}  // namespace panoscan
