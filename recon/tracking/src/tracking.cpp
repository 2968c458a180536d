// Joint tracking of the unsynchronized cameras (paper §4.1): options, the one-call entry and the
// stats file. The steps of the graph are in tracking_graph.{h,cpp}, the check of the solution in
// tracking_verify.cpp; the choices are documented in tracking.h.
#include "panoscan/recon/tracking.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/timer.h"
#include "panoscan/core/version.h"
#include "tracking_graph.h"

namespace panoscan {

void TrackingOptions::check(const std::string& origin) const {
  auto require = [&](bool ok, const char* field, const char* what) {
    if (!ok) throw make_error(origin, field, what);
  };
  require(reg_translation_std_m > 0, "track.reg_translation_std_m", "must be > 0");
  require(reg_rotation_std_deg > 0, "track.reg_rotation_std_deg", "must be > 0");
  require(angular_accel_std_deg_s2 > 0, "track.angular_accel_std_deg_s2", "must be > 0");
  require(extrinsics_prior_translation_std_m > 0, "track.extrinsics_prior_translation_std_m", "must be > 0");
  require(extrinsics_prior_rotation_std_deg > 0, "track.extrinsics_prior_rotation_std_deg", "must be > 0");
  require(wobble_rate_std_deg_s > 0, "track.wobble_rate_std_deg_s", "must be > 0");
  require(wobble_rate_std_m_s > 0, "track.wobble_rate_std_m_s", "must be > 0");
  require(same_time_s >= 0 && same_time_s < 0.1, "track.same_time_s", "must be in [0, 0.1)");
  require(huber_delta > 0, "track.huber_delta", "must be > 0");
  require(depth_noise_coefficient > 0, "track.depth_noise_coefficient", "must be > 0");
  require(max_iterations >= 1 && max_iterations <= 10000, "track.max_iterations", "must be in [1, 10000]");
  require(function_tolerance > 0 && function_tolerance < 1, "track.function_tolerance", "must be in (0, 1)");
  require(
      initial_trust_region_radius == 0.0 || (initial_trust_region_radius >= 1.0 && initial_trust_region_radius <= 1e16),
      "track.initial_trust_region_radius", "must be 0 (automatic) or in [1, 1e16]");
  require(linear_solver == "sparse_schur" || linear_solver == "sparse_normal_cholesky" ||
              linear_solver == "iterative_schur" || linear_solver == "dense_schur",
          "track.linear_solver", "must be sparse_schur, dense_schur, iterative_schur or sparse_normal_cholesky");
  require(threads >= 0, "threads", "must be >= 0");
  require(solver_threads >= 0, "track.solver_threads", "must be >= 0");
  require(depth_odometry_block_px >= 1 && depth_odometry_block_px <= 64, "track.depth_odometry_block_px",
          "must be in [1, 64]");
  require(depth_odometry_information_scale > 0 && depth_odometry_information_scale <= 1e6,
          "track.depth_odometry_information_scale", "must be in (0, 1e6]");
  require(depth_odometry_max_distance_m > 0 && depth_odometry_max_distance_m <= 10,
          "track.depth_odometry_max_distance_m", "must be in (0, 10]");
  require(depth_odometry_min_overlap >= 0 && depth_odometry_min_overlap <= 1, "track.depth_odometry_min_overlap",
          "must be in [0, 1]");
  frontend.check(origin);
  verify.check(origin);
}

void TrackingVerifyOptions::check(const std::string& origin) const {
  auto require = [&](bool ok, const char* field, const char* what) {
    if (!ok) throw make_error(origin, field, what);
  };
  require(min_frame_observations >= 1, "track.verify.min_frame_observations", "must be >= 1");
  require(max_unsupported_turn_deg > 0, "track.verify.max_unsupported_turn_deg", "must be > 0");
  require(min_turn_deg >= 0 && min_turn_deg <= max_turn_deg, "track.verify.min_turn_deg",
          "must be >= 0 and at most track.verify.max_turn_deg");
  require(max_backward_step_deg >= 0, "track.verify.max_backward_step_deg", "must be >= 0");
  require(min_pair_inlier_share > 0 && min_pair_inlier_share <= 1, "track.verify.min_pair_inlier_share",
          "must be in (0, 1]");
  require(min_consistent_pair_share >= 0 && min_consistent_pair_share <= 1, "track.verify.min_consistent_pair_share",
          "must be in [0, 1]");
  require(min_consistent_loop_share >= 0 && min_consistent_loop_share <= 1, "track.verify.min_consistent_loop_share",
          "must be in [0, 1]");
  require(max_outlier_share >= 0 && max_outlier_share <= 1, "track.verify.max_outlier_share", "must be in [0, 1]");
  require(max_extrinsics_change_deg > 0, "track.verify.max_extrinsics_change_deg", "must be > 0");
  require(max_extrinsics_change_m > 0, "track.verify.max_extrinsics_change_m", "must be > 0");
  require(max_axis_tilt_deg > 0 && max_axis_tilt_deg <= 180, "track.verify.max_axis_tilt_deg", "must be in (0, 180]");
  require(max_unsupported_s > 0, "track.verify.max_unsupported_s", "must be > 0");
  require(max_depth_yaw_std_deg >= 0 && std::isfinite(max_depth_yaw_std_deg), "track.verify.max_depth_yaw_std_deg",
          "must be >= 0 (0: depth odometry never supports a frame)");
  require(max_model_departure_sigma > 0 && std::isfinite(max_model_departure_sigma),
          "track.verify.max_model_departure_sigma", "must be > 0");
}

const char* to_string(TrackingMode mode) {
  switch (mode) {
    case TrackingMode::kFull: return "full";
    case TrackingMode::kBaOnly: return "ba-only";
    case TrackingMode::kSingleCamera: return "single-camera";
    case TrackingMode::kFixedExtrinsics: return "fixed-extrinsics";
  }
  return "?";
}

TrackingMode tracking_mode_from_string(const std::string& text, const std::string& origin) {
  for (TrackingMode mode :
       {TrackingMode::kFull, TrackingMode::kBaOnly, TrackingMode::kSingleCamera, TrackingMode::kFixedExtrinsics})
    if (text == to_string(mode)) return mode;
  throw make_error(origin, "track.mode", "'" + text + "' is not one of full, ba-only, single-camera, fixed-extrinsics");
}

TrackingOptions tracking_options_from_config(Config& config) {
  TrackingOptions o;
  o.mode = tracking_mode_from_string(
      config.get_string("track.mode", "full", {"full", "ba-only", "single-camera", "fixed-extrinsics"}),
      config.origin());
  o.pose_regularisation = config.get_bool("track.pose_regularisation", o.pose_regularisation);
  o.velocity_smoothness = config.get_bool("track.velocity_smoothness", o.velocity_smoothness);
  o.reg_translation_std_m = config.get_double("track.reg_translation_std_m", o.reg_translation_std_m, 1e-6, 1.0);
  o.reg_rotation_std_deg = config.get_double("track.reg_rotation_std_deg", o.reg_rotation_std_deg, 1e-4, 45.0);
  o.angular_accel_std_deg_s2 =
      config.get_double("track.angular_accel_std_deg_s2", o.angular_accel_std_deg_s2, 1e-4, 1e4);
  o.velocity_std_scales_with_dt = config.get_bool("track.velocity_std_scales_with_dt", o.velocity_std_scales_with_dt);
  o.extrinsics_prior_translation_std_m =
      config.get_double("track.extrinsics_prior_translation_std_m", o.extrinsics_prior_translation_std_m, 1e-6, 10.0);
  o.extrinsics_prior_rotation_std_deg =
      config.get_double("track.extrinsics_prior_rotation_std_deg", o.extrinsics_prior_rotation_std_deg, 1e-4, 180.0);
  o.extrinsics_null_prior = config.get_bool("track.extrinsics_null_prior", o.extrinsics_null_prior);
  o.extrinsics_release_min_landmarks =
      config.get_int("track.extrinsics_release_min_landmarks", o.extrinsics_release_min_landmarks, 1, 100000000);
  o.hold_extrinsics_slide = config.get_bool("track.hold_extrinsics_slide", o.hold_extrinsics_slide);
  o.shared_wobble = config.get_bool("track.shared_wobble", o.shared_wobble);
  o.wobble_rate_std_deg_s = config.get_double("track.wobble_rate_std_deg_s", o.wobble_rate_std_deg_s, 1e-3, 1e4);
  o.wobble_rate_std_m_s = config.get_double("track.wobble_rate_std_m_s", o.wobble_rate_std_m_s, 1e-5, 100.0);
  o.same_time_s = config.get_double("track.same_time_s", o.same_time_s, 0.0, 0.099);
  o.depth_odometry = config.get_bool("track.depth_odometry", o.depth_odometry);
  o.depth_odometry_block_px = config.get_int("track.depth_odometry_block_px", o.depth_odometry_block_px, 1, 64);
  o.depth_odometry_information_scale =
      config.get_double("track.depth_odometry_information_scale", o.depth_odometry_information_scale, 1e-9, 1e6);
  o.depth_odometry_max_distance_m =
      config.get_double("track.depth_odometry_max_distance_m", o.depth_odometry_max_distance_m, 1e-4, 10.0);
  o.depth_odometry_min_overlap =
      config.get_double("track.depth_odometry_min_overlap", o.depth_odometry_min_overlap, 0.0, 1.0);
  o.huber_delta = config.get_double("track.huber_delta", o.huber_delta, 1e-3, 1e3);
  o.depth_noise_coefficient = config.get_double("track.depth_noise_coefficient", o.depth_noise_coefficient, 1e-6, 1.0);
  o.max_iterations = config.get_int("track.max_iterations", o.max_iterations, 1, 10000);
  o.function_tolerance = config.get_double("track.function_tolerance", o.function_tolerance, 1e-15, 0.5);
  o.initial_trust_region_radius =
      config.get_double("track.initial_trust_region_radius", o.initial_trust_region_radius, 0.0, 1e16);
  o.log_iterations = config.get_bool("track.log_iterations", o.log_iterations);
  o.linear_solver = config.get_string("track.linear_solver", o.linear_solver,
                                      {"sparse_schur", "dense_schur", "iterative_schur", "sparse_normal_cholesky"});
  o.schur_ordering = config.get_string("track.schur_ordering", o.schur_ordering, {"landmarks", "automatic"});
  o.threads = config.get_int("threads", 0, 0, 1024);
  o.solver_threads = config.get_int("track.solver_threads", o.solver_threads, 0, 1024);
  FrontendOptions& f = o.frontend;
  f.orb_features = config.get_int("frontend.orb_features", f.orb_features, 50, 20000);
  f.orb_levels = config.get_int("frontend.orb_levels", f.orb_levels, 0, 16);
  f.orb_scale_factor = config.get_double("frontend.orb_scale_factor", f.orb_scale_factor, 1.01, 2.0);
  f.orb_fast_threshold = config.get_int("frontend.orb_fast_threshold", f.orb_fast_threshold, 1, 255);
  f.same_camera_window = config.get_int("frontend.same_camera_window", f.same_camera_window, 1, 100);
  f.guided_matching = config.get_bool("frontend.guided_matching", f.guided_matching);
  f.guide_keypoints = config.get_int("frontend.guide_keypoints", f.guide_keypoints, 3, 100000);
  f.guided_radius_px = config.get_double("frontend.guided_radius_px", f.guided_radius_px, 0.5, 640.0);
  f.cross_camera = config.get_bool("frontend.cross_camera", f.cross_camera);
  f.loop_closure = config.get_bool("frontend.loop_closure", f.loop_closure);
  f.loop_frames = config.get_int("frontend.loop_frames", f.loop_frames, 0, 100);
  f.orb_border_px = config.get_int("frontend.orb_border_px", f.orb_border_px, 0, 100);
  f.loop_max_deviation_deg = config.get_double("frontend.loop_max_deviation_deg", f.loop_max_deviation_deg, 0.0, 180.0);
  f.loop_max_deviation_m = config.get_double("frontend.loop_max_deviation_m", f.loop_max_deviation_m, 0.0, 100.0);
  f.max_pair_translation_m =
      config.get_double("frontend.max_pair_translation_m", f.max_pair_translation_m, 1e-3, 100.0);
  f.ransac_iterations = config.get_int("frontend.ransac_iterations", f.ransac_iterations, 1, 100000);
  f.ransac_confidence = config.get_double("frontend.ransac_confidence", f.ransac_confidence, 1e-6, 1.0);
  f.ransac_min_iterations = config.get_int("frontend.ransac_min_iterations", f.ransac_min_iterations, 0, 100000);
  f.min_inliers = config.get_int("frontend.min_inliers", f.min_inliers, 3, 10000);
  f.min_cross_inliers = config.get_int("frontend.min_cross_inliers", f.min_cross_inliers, 3, 10000);
  f.band_matching = config.get_bool("frontend.band_matching", f.band_matching);
  f.band_patch_long_px = config.get_int("frontend.band_patch_long_px", f.band_patch_long_px, 3, 63);
  f.band_patch_short_px = config.get_int("frontend.band_patch_short_px", f.band_patch_short_px, 3, 63);
  f.band_search_deg = config.get_double("frontend.band_search_deg", f.band_search_deg, 0.01, 5.0);
  f.band_refine_px = config.get_int("frontend.band_refine_px", f.band_refine_px, 1, 20);
  f.band_min_ncc = config.get_double("frontend.band_min_ncc", f.band_min_ncc, 0.01, 0.999);
  f.band_min_contrast = config.get_double("frontend.band_min_contrast", f.band_min_contrast, 0.0, 255.0);
  f.band_peak_ratio = config.get_double("frontend.band_peak_ratio", f.band_peak_ratio, 1.0, 100.0);
  f.band_min_gradient = config.get_double("frontend.band_min_gradient", f.band_min_gradient, 0.0, 255.0);
  f.band_peak_margin = config.get_double("frontend.band_peak_margin", f.band_peak_margin, 0.0, 2.0);
  f.band_max_shift_spread_px =
      config.get_double("frontend.band_max_shift_spread_px", f.band_max_shift_spread_px, 0.01, 100.0);
  f.band_depth_slack_m = config.get_double("frontend.band_depth_slack_m", f.band_depth_slack_m, 0.0, 10.0);
  f.band_frames = config.get_int("frontend.band_frames", f.band_frames, 1, 20);
  f.band_calibration_pairs = config.get_int("frontend.band_calibration_pairs", f.band_calibration_pairs, 1, 100000);
  f.seed = config.get_u64("seed", f.seed);
  f.threads = o.threads;
  f.depth_noise_coefficient = o.depth_noise_coefficient;
  // The front end keeps the depth grids the depth odometry aligns (decoded once).
  f.depth_grid_block = o.depth_odometry ? o.depth_odometry_block_px : 0;
  o.allow_unreliable = config.get_bool("track.allow_unreliable", o.allow_unreliable);
  TrackingVerifyOptions& v = o.verify;
  v.enabled = config.get_bool("track.verify.enabled", v.enabled);
  v.min_frame_observations = config.get_int("track.verify.min_frame_observations", v.min_frame_observations, 1, 10000);
  v.max_unsupported_turn_deg =
      config.get_double("track.verify.max_unsupported_turn_deg", v.max_unsupported_turn_deg, 1e-3, 720.0);
  v.min_turn_deg = config.get_double("track.verify.min_turn_deg", v.min_turn_deg, 0.0, 3600.0);
  v.max_turn_deg = config.get_double("track.verify.max_turn_deg", v.max_turn_deg, 0.0, 3600.0);
  v.max_backward_step_deg =
      config.get_double("track.verify.max_backward_step_deg", v.max_backward_step_deg, 0.0, 360.0);
  v.min_pair_inlier_share = config.get_double("track.verify.min_pair_inlier_share", v.min_pair_inlier_share, 1e-6, 1.0);
  v.min_consistent_pair_share =
      config.get_double("track.verify.min_consistent_pair_share", v.min_consistent_pair_share, 0.0, 1.0);
  v.min_consistent_loop_share =
      config.get_double("track.verify.min_consistent_loop_share", v.min_consistent_loop_share, 0.0, 1.0);
  v.max_outlier_share = config.get_double("track.verify.max_outlier_share", v.max_outlier_share, 0.0, 1.0);
  v.max_extrinsics_change_deg =
      config.get_double("track.verify.max_extrinsics_change_deg", v.max_extrinsics_change_deg, 1e-4, 180.0);
  v.max_extrinsics_change_m =
      config.get_double("track.verify.max_extrinsics_change_m", v.max_extrinsics_change_m, 1e-6, 10.0);
  v.max_axis_tilt_deg = config.get_double("track.verify.max_axis_tilt_deg", v.max_axis_tilt_deg, 1e-3, 180.0);
  v.max_unsupported_s = config.get_double("track.verify.max_unsupported_s", v.max_unsupported_s, 1e-3, 3600.0);
  v.max_depth_yaw_std_deg =
      config.get_double("track.verify.max_depth_yaw_std_deg", v.max_depth_yaw_std_deg, 0.0, 180.0);
  v.max_model_departure_sigma =
      config.get_double("track.verify.max_model_departure_sigma", v.max_model_departure_sigma, 1e-3, 1e6);
  o.check(config.origin());
  return o;
}

TrackingResult track_with_frontend(const ScanIndex& scan, const FrontendResult& frontend,
                                   const TrackingOptions& options, const RigTrajectory* initial_guess) {
  namespace tg = tracking_graph;
  options.check();
  const SteadyTime start = steady_now();
  tg::TrackingState state = tg::initialise_tracking_state(scan, frontend, options, initial_guess);
  const SteadyTime init_done = steady_now();

  // The factor graph (Eq. 4: sum of Eq. 3, Eq. 2 and Huber(Eq. 1)), then the solve.
  tg::FactorGraph graph;
  tg::add_observation_factors(graph, state, scan, frontend, options);
  tg::add_regularisation_factors(graph, state, options);
  tg::add_shared_wobble_factors(graph, state, options);
  tg::add_velocity_factors(graph, state, options);
  const SteadyTime depth_start = steady_now();
  tg::add_depth_odometry_factors(graph, state, scan, frontend, options);
  const double depth_seconds = seconds_between(depth_start, steady_now());
  tg::fix_gauge(graph, state, options);
  TrackingStats stats;
  stats.mode = to_string(options.mode);
  stats.initial_term_costs = graph.term_costs();
  const ceres::Solver::Summary summary = tg::solve_tracking_graph(graph, options, state.origin, &stats.threads);
  stats.final_term_costs = graph.term_costs();
  const SteadyTime solve_done = steady_now();

  bool all_finite = true;
  TrackingResult result = tg::extract_tracking_result(state, scan, options, &all_finite);
  result.depth_pair_residual = tg::depth_pair_residual_norms(graph, state);
  tg::ModelDeparture departure = tg::model_departures(graph, state, options);
  result.model_departure_mm = std::move(departure.translation_mm);
  result.model_departure_deg = std::move(departure.rotation_deg);
  for (int s = 0; s < state.sensor_count; ++s) {
    if (!state.active[s]) continue;
    stats.frames += int(state.poses[s].size());
    for (int count : state.observation_count[s]) stats.frames_without_observations += count == 0;
  }
  stats.observations = int(graph.blocks[tg::kObservation].size());
  stats.shared_wobble_links = graph.shared_wobble_links;
  stats.depth_pairs = graph.depth_pairs;
  stats.depth_pairs_rejected = graph.depth_pairs_rejected;
  stats.depth_icp_iterations = graph.depth_icp_iterations;
  stats.depth_odometry_seconds = depth_seconds;
  stats.extrinsics_observed = state.extrinsics_observed;
  stats.extrinsics_slide_held = options.hold_extrinsics_slide;
  stats.landmarks = int(state.tracks.size());
  stats.residual_blocks = graph.problem->NumResidualBlocks();
  stats.parameters = graph.problem->NumParameters();
  stats.iterations = int(summary.iterations.size()) - 1;
  stats.initial_cost = summary.initial_cost;
  stats.final_cost = summary.final_cost;
  stats.converged = summary.termination_type == ceres::CONVERGENCE && all_finite;
  stats.termination = summary.message;
  stats.linear_solver = options.linear_solver;
  stats.frontend_seconds = frontend.total_seconds;
  stats.feature_ms_per_frame = frontend.feature_ms_per_frame;
  stats.orb_levels = frontend.orb_levels;
  stats.matching_ms_per_frame = frontend.matching_ms_per_frame;
  stats.same_camera_pairs = frontend.same_camera_pairs;
  stats.cross_camera_pairs = frontend.cross_camera_pairs;
  stats.loop_pairs = frontend.loop_pairs;
  stats.rejected_loop_pairs = frontend.rejected_loop_pairs;
  stats.rejected_far_pairs = frontend.rejected_far_pairs;
  stats.cross_camera = frontend.cross_camera;
  stats.cross_landmarks = frontend.cross_landmarks;
  stats.cross_observations = frontend.cross_observations;
  stats.frames_without_features = frontend.frames_without_features;
  stats.guided_pairs = frontend.guided_pairs;
  stats.guided_fallbacks = frontend.guided_fallbacks;
  stats.init_seconds = seconds_between(start, init_done);
  stats.solve_seconds = seconds_between(init_done, solve_done) - depth_seconds;  // the ICP is reported on its own
  stats.linear_solver_seconds = summary.linear_solver_time_in_seconds;
  stats.jacobian_seconds = summary.jacobian_evaluation_time_in_seconds;
  if (!stats.converged)
    log_warn(state.origin + ": tracking did not converge (" + summary.message +
             (all_finite ? "" : "; non-finite poses") + ")");
  result.stats = stats;

  // Does the solution hold up? (tracking_verify.cpp)
  std::vector<std::vector<int>> observations(state.sensor_count);
  for (int s = 0; s < state.sensor_count; ++s)
    if (state.active[s]) observations[s] = state.observation_count[s];
  if (options.verify.enabled) {
    result.verdict =
        verify_tracking(result, scan, frontend, observations, tg::observation_residual_norms(graph), options);
    // A released camera that moved too far from its calibration: solve again with its slide along
    // the axis held (TrackingOptions::hold_extrinsics_slide), and keep that solve, reliable or not.
    bool extrinsics_failed = false;
    for (const TrackingCheck& check : result.verdict.checks)
      extrinsics_failed |= check.name == "extrinsics" && !check.passed;
    bool released = false;
    for (int s = 0; s < state.sensor_count; ++s)
      released |= s != state.ref && state.active[s] && state.extrinsics_observed[s];
    if (extrinsics_failed && released && options.extrinsics_null_prior && !options.hold_extrinsics_slide) {
      const std::string failure = result.verdict.first_failure();
      log_warn(state.origin + ": " + failure + "; solving again with the slide along the axis held at the calibration");
      TrackingOptions held = options;
      held.hold_extrinsics_slide = true;
      TrackingResult again = track_with_frontend(scan, frontend, held, initial_guess);
      again.stats.first_solve_failure = failure;
      again.stats.solve_seconds += result.stats.solve_seconds;
      return again;
    }
    if (!result.verdict.reliable)
      log_warn(state.origin + ": tracking is not trustworthy: " + result.verdict.first_failure());
  }
  return result;
}

TrackingResult track_scan(const ScanIndex& scan, const TrackingOptions& options) {
  options.check();
  FrontendOptions frontend_options = options.frontend;
  frontend_options.threads = options.threads;
  frontend_options.depth_noise_coefficient = options.depth_noise_coefficient;
  if (options.mode == TrackingMode::kSingleCamera) frontend_options.sensors = {scan.rig.reference_sensor};
  frontend_options.depth_grid_block =
      options.depth_odometry && options.mode != TrackingMode::kBaOnly ? options.depth_odometry_block_px : 0;
  // The loop closure pairs the end of the turn with its start and keeps only pairs that fit an
  // in-place rotation (frontend.h); a handheld recording has neither.
  if (scan.rig.motion == RigMotion::kHandheld && frontend_options.loop_closure) {
    frontend_options.loop_closure = false;
    log_info(scan.root.string() + ": handheld recording: no end-of-turn loop closure");
  }
  const FrontendResult frontend = run_frontend(scan, frontend_options);
  log_info("front end: " + std::to_string(frontend.landmarks.size()) + " landmarks, " +
           std::to_string(frontend.same_camera_pairs) + " same-camera, " + std::to_string(frontend.cross_camera_pairs) +
           " cross-camera, " + std::to_string(frontend.loop_pairs) + " loop pairs (" +
           std::to_string(frontend.rejected_loop_pairs) + " loop and " + std::to_string(frontend.rejected_far_pairs) +
           " far pairs rejected)");
  const CrossCameraFunnel& funnel = frontend.cross_camera;
  if (funnel.band_candidates > 0) {
    std::string corrections;
    for (const auto& r : funnel.band_relations)
      corrections += fmt::format("{}cam{}-cam{} {:.2f} deg ({} votes)", corrections.empty() ? "" : ", ", r.sensor_a,
                                 r.sensor_b, r.correction_deg, r.votes);
    log_info(
        fmt::format("band alignment across cameras: {} frame pairs, {} with corners predicted in the other view, "
                    "{} accepted ({} corners, {} aligned, {} matches); calibration correction {}",
                    funnel.band_candidates, funnel.band_with_anchors, funnel.band_accepted, funnel.band_anchors,
                    funnel.band_aligned, funnel.band_matches, corrections));
  }
  if (funnel.candidates > 0)
    log_info("cross-camera pairs: " + std::to_string(funnel.candidates) + " candidates, " +
             std::to_string(funnel.with_band_keypoints) + " with keypoints in the band, " +
             std::to_string(funnel.with_matches) + " with matches, " + std::to_string(funnel.with_ransac) +
             " through RANSAC, " + std::to_string(funnel.accepted) + " agreeing with the calibration (" +
             std::to_string(funnel.band_keypoints_a + funnel.band_keypoints_b) + " band keypoints, " +
             std::to_string(funnel.matches) + " matches, " + std::to_string(funnel.inliers) + " inliers in all)");
  return track_with_frontend(scan, frontend, options);
}

namespace {

nlohmann::json stats_to_json(const TrackingStats& s) {
  nlohmann::json band_relations = nlohmann::json::array();
  for (const auto& r : s.cross_camera.band_relations)
    band_relations.push_back(
        {{"sensors", {r.sensor_a, r.sensor_b}}, {"votes", r.votes}, {"calibration_correction_deg", r.correction_deg}});
  std::vector<bool> extrinsics_observed(s.extrinsics_observed.begin(), s.extrinsics_observed.end());
  nlohmann::json j = {
      {"format", "panoscan-tracking-stats"},
      {"version", 1},
      {"mode", s.mode},
      {"frames", s.frames},
      {"landmarks", s.landmarks},
      {"observations", s.observations},
      {"frames_without_observations", s.frames_without_observations},
      {"frames_without_features", s.frames_without_features},
      {"pairs",
       {{"same_camera", s.same_camera_pairs},
        {"cross_camera", s.cross_camera_pairs},
        {"loop", s.loop_pairs},
        {"rejected_loop", s.rejected_loop_pairs},
        {"rejected_far", s.rejected_far_pairs},
        {"guided", s.guided_pairs},
        {"guided_fallback", s.guided_fallbacks}}},
      {"cross_camera_funnel",
       {{"candidates", s.cross_camera.candidates},
        {"with_band_keypoints", s.cross_camera.with_band_keypoints},
        {"with_matches", s.cross_camera.with_matches},
        {"with_ransac", s.cross_camera.with_ransac},
        {"accepted", s.cross_camera.accepted},
        {"band_keypoints", {s.cross_camera.band_keypoints_a, s.cross_camera.band_keypoints_b}},
        {"matches", s.cross_camera.matches},
        {"inliers", s.cross_camera.inliers},
        {"unpredicted", s.cross_camera.unpredicted},
        {"band",
         {{"candidates", s.cross_camera.band_candidates},
          {"unpredicted", s.cross_camera.band_unpredicted},
          {"with_anchors", s.cross_camera.band_with_anchors},
          {"accepted", s.cross_camera.band_accepted},
          {"anchors", s.cross_camera.band_anchors},
          {"aligned", s.cross_camera.band_aligned},
          {"matches", s.cross_camera.band_matches},
          {"camera_pairs", band_relations}}}}},
      {"cross_camera_per_sensor",
       {{"landmarks", s.cross_landmarks},
        {"observations", s.cross_observations},
        {"extrinsics_observed", extrinsics_observed},
        {"extrinsics_slide_held", s.extrinsics_slide_held},
        {"first_solve_failure", s.first_solve_failure}}},
      {"residual_blocks", s.residual_blocks},
      {"parameters", s.parameters},
      {"iterations", s.iterations},
      {"initial_cost", s.initial_cost},
      {"final_cost", s.final_cost},
      {"term_costs",
       {{"order", {"observation", "regularisation", "velocity", "priors", "shared_wobble", "depth_odometry"}},
        {"initial", s.initial_term_costs},
        {"final", s.final_term_costs}}},
      {"shared_wobble_links", s.shared_wobble_links},
      {"depth_odometry",
       {{"pairs", s.depth_pairs},
        {"rejected", s.depth_pairs_rejected},
        {"icp_iterations_per_pair",
         s.depth_pairs + s.depth_pairs_rejected > 0
             ? double(s.depth_icp_iterations) / double(s.depth_pairs + s.depth_pairs_rejected)
             : 0.0},
        {"seconds", s.depth_odometry_seconds}}},
      {"converged", s.converged},
      {"termination", s.termination},
      {"linear_solver", s.linear_solver},
      {"threads", s.threads},
      {"seconds",
       {{"frontend", s.frontend_seconds},
        {"init", s.init_seconds},
        {"solve", s.solve_seconds},
        {"linear_solver", s.linear_solver_seconds},
        {"jacobians", s.jacobian_seconds}}},
      {"frontend_ms_per_frame", {{"features", s.feature_ms_per_frame}, {"matching", s.matching_ms_per_frame}}},
      {"orb_levels", s.orb_levels}};
  return j;
}

}  // namespace

std::string tracking_stats_json(const TrackingStats& stats) { return stats_to_json(stats).dump(2) + "\n"; }

std::string tracking_stats_json(const TrackingResult& result, const RigInfo& rig) {
  nlohmann::json j = stats_to_json(result.stats);
  const TrackingVerdict& v = result.verdict;
  nlohmann::json checks = nlohmann::json::array();
  for (const TrackingCheck& c : v.checks)
    checks.push_back(
        {{"name", c.name}, {"passed", c.passed}, {"value", c.value}, {"limit", c.limit}, {"detail", c.detail}});
  j["verdict"] = {{"checked", v.checked},
                  {"reliable", v.reliable},
                  {"first_failure", v.first_failure()},
                  {"checks", std::move(checks)}};
  nlohmann::json frames = nlohmann::json::object();
  for (std::size_t s = 0; s < v.frames.size() && s < rig.sensors.size(); ++s) {
    nlohmann::json observations = nlohmann::json::array(), gap = nlohmann::json::array(),
                   gap_s = nlohmann::json::array(), confidence = nlohmann::json::array(),
                   depth_yaw = nlohmann::json::array(), depth_supported = nlohmann::json::array(),
                   depth_residual = nlohmann::json::array(), departure_mm = nlohmann::json::array(),
                   departure_deg = nlohmann::json::array();
    for (const FrameSupport& f : v.frames[s]) {
      observations.push_back(f.observations);
      // null: no depth-odometry pair (JSON has no infinity).
      depth_yaw.push_back(std::isfinite(f.depth_yaw_std_deg) ? nlohmann::json(f.depth_yaw_std_deg) : nlohmann::json());
      depth_supported.push_back(f.depth_supported);
      depth_residual.push_back(std::isfinite(f.depth_residual) ? nlohmann::json(f.depth_residual) : nlohmann::json());
      departure_mm.push_back(f.model_departure_mm);
      departure_deg.push_back(f.model_departure_deg);
      gap.push_back(f.gap_deg);
      gap_s.push_back(f.gap_s);
      confidence.push_back(f.confidence);
    }
    frames[rig.sensors[s].name] = {{"observations", std::move(observations)},
                                   {"gap_deg", std::move(gap)},
                                   {"gap_s", std::move(gap_s)},
                                   {"depth_yaw_std_deg", std::move(depth_yaw)},
                                   {"depth_supported", std::move(depth_supported)},
                                   {"depth_residual", std::move(depth_residual)},
                                   {"model_departure_mm", std::move(departure_mm)},
                                   {"model_departure_deg", std::move(departure_deg)},
                                   {"confidence", std::move(confidence)}};
  }
  j["frame_support"] = std::move(frames);
  return j.dump(2) + "\n";
}

void write_tracking_result(const std::filesystem::path& dir, const TrackingResult& result, const RigInfo& rig,
                           const std::filesystem::path& scan_dir) {
  std::filesystem::create_directories(dir);
  if (result.verdict.reliable) {
    write_rig_trajectory(dir, result.trajectory, rig);
  } else {
    RigTrajectory marked = result.trajectory;
    marked.source += ":unreliable";
    write_rig_trajectory(dir, marked, rig);
  }
  nlohmann::json stats = nlohmann::json::parse(tracking_stats_json(result, rig));
  stats["written_by"] = {{"version", project_version()}, {"source_revision", source_revision()}};
  if (!scan_dir.empty()) stats["scan"] = std::filesystem::absolute(scan_dir).lexically_normal().string();
  write_file_atomic(dir / "tracking_stats.json", stats.dump(2) + "\n");
}

}  // namespace panoscan
