// Joint tracking of the unsynchronized cameras (paper §4.1): builds the factor graph of Eq. 1-3
// on the front end's landmarks and solves it with Ceres. See tracking.h for the choices.
//
// Solver: Levenberg-Marquardt with SPARSE_SCHUR by default: the landmarks (3 parameters each, the
// large majority) form an independent set that Ceres eliminates first (its automatic ordering), and
// the reduced camera system over poses, azimuths, T_u and T_c is sparse (banded by Eq. 3 and the
// frame-to-frame tracks) and factored by SuiteSparse/CHOLMOD. SPARSE_NORMAL_CHOLESKY is the option
// for graphs with few landmarks. Residuals and Jacobians are evaluated on `threads` threads.
#include "panoscan/recon/tracking.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "panoscan/core/atomic_output.h"
#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "tracking_factors.h"
#include "tracking_init.h"

namespace panoscan {

namespace tf = tracking_factors;

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
  require(linear_solver == "sparse_schur" || linear_solver == "sparse_normal_cholesky", "track.linear_solver",
          "must be sparse_schur or sparse_normal_cholesky");
  require(threads >= 0, "threads", "must be >= 0");
  frontend.check(origin);
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
  for (TrackingMode mode : {TrackingMode::kFull, TrackingMode::kBaOnly, TrackingMode::kSingleCamera,
                            TrackingMode::kFixedExtrinsics})
    if (text == to_string(mode)) return mode;
  throw make_error(origin, "track.mode", "'" + text + "' is not one of full, ba-only, single-camera, fixed-extrinsics");
}

TrackingOptions tracking_options_from_config(Config& config) {
  TrackingOptions o;
  o.mode = tracking_mode_from_string(
      config.get_string("track.mode", "full", {"full", "ba-only", "single-camera", "fixed-extrinsics"}), config.origin());
  o.pose_regularisation = config.get_bool("track.pose_regularisation", o.pose_regularisation);
  o.velocity_smoothness = config.get_bool("track.velocity_smoothness", o.velocity_smoothness);
  o.reg_translation_std_m = config.get_double("track.reg_translation_std_m", o.reg_translation_std_m, 1e-6, 1.0);
  o.reg_rotation_std_deg = config.get_double("track.reg_rotation_std_deg", o.reg_rotation_std_deg, 1e-4, 45.0);
  o.angular_accel_std_deg_s2 = config.get_double("track.angular_accel_std_deg_s2", o.angular_accel_std_deg_s2, 1e-4, 1e4);
  o.velocity_std_scales_with_dt = config.get_bool("track.velocity_std_scales_with_dt", o.velocity_std_scales_with_dt);
  o.extrinsics_prior_translation_std_m =
      config.get_double("track.extrinsics_prior_translation_std_m", o.extrinsics_prior_translation_std_m, 1e-6, 10.0);
  o.extrinsics_prior_rotation_std_deg =
      config.get_double("track.extrinsics_prior_rotation_std_deg", o.extrinsics_prior_rotation_std_deg, 1e-4, 180.0);
  o.extrinsics_null_prior = config.get_bool("track.extrinsics_null_prior", o.extrinsics_null_prior);
  o.shared_wobble = config.get_bool("track.shared_wobble", o.shared_wobble);
  o.wobble_rate_std_deg_s = config.get_double("track.wobble_rate_std_deg_s", o.wobble_rate_std_deg_s, 1e-3, 1e4);
  o.wobble_rate_std_m_s = config.get_double("track.wobble_rate_std_m_s", o.wobble_rate_std_m_s, 1e-5, 100.0);
  o.same_time_s = config.get_double("track.same_time_s", o.same_time_s, 0.0, 0.099);
  o.huber_delta = config.get_double("track.huber_delta", o.huber_delta, 1e-3, 1e3);
  o.depth_noise_coefficient = config.get_double("track.depth_noise_coefficient", o.depth_noise_coefficient, 1e-6, 1.0);
  o.max_iterations = config.get_int("track.max_iterations", o.max_iterations, 1, 10000);
  o.function_tolerance = config.get_double("track.function_tolerance", o.function_tolerance, 1e-15, 0.5);
  o.log_iterations = config.get_bool("track.log_iterations", o.log_iterations);
  o.linear_solver = config.get_string("track.linear_solver", o.linear_solver, {"sparse_schur", "sparse_normal_cholesky"});
  o.threads = config.get_int("threads", 0, 0, 1024);
  FrontendOptions& f = o.frontend;
  f.orb_features = config.get_int("frontend.orb_features", f.orb_features, 50, 20000);
  f.same_camera_window = config.get_int("frontend.same_camera_window", f.same_camera_window, 1, 100);
  f.cross_camera = config.get_bool("frontend.cross_camera", f.cross_camera);
  f.loop_closure = config.get_bool("frontend.loop_closure", f.loop_closure);
  f.loop_frames = config.get_int("frontend.loop_frames", f.loop_frames, 0, 100);
  f.ransac_iterations = config.get_int("frontend.ransac_iterations", f.ransac_iterations, 1, 100000);
  f.min_inliers = config.get_int("frontend.min_inliers", f.min_inliers, 3, 10000);
  f.min_cross_inliers = config.get_int("frontend.min_cross_inliers", f.min_cross_inliers, 3, 10000);
  f.seed = config.get_u64("seed", f.seed);
  f.threads = o.threads;
  f.depth_noise_coefficient = o.depth_noise_coefficient;
  o.check(config.origin());
  return o;
}

namespace {

// A pose in Ceres' layout: unit quaternion (w, x, y, z) and translation.
struct PoseBlock {
  double q[4] = {1, 0, 0, 0};
  double t[3] = {0, 0, 0};

  static PoseBlock from(const Rigid3d& pose) {
    PoseBlock block;
    const Eigen::Quaterniond q(pose.linear());
    block.q[0] = q.w();
    block.q[1] = q.x();
    block.q[2] = q.y();
    block.q[3] = q.z();
    for (int k = 0; k < 3; ++k) block.t[k] = pose.translation()[k];
    return block;
  }
  Rigid3d pose() const {
    return make_rigid(Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
  }
};

Rigid3d axis_rotation(double alpha) { return rotation_about(Eigen::Vector3d::UnitZ(), alpha); }

// Piecewise-linear azimuth of time through (times, alphas) (sorted), extrapolated with the end slopes.
double interpolate(const std::vector<double>& times, const std::vector<double>& alphas, double t) {
  if (times.size() == 1) return alphas[0];
  std::size_t i = std::upper_bound(times.begin(), times.end(), t) - times.begin();
  i = std::clamp<std::size_t>(i, 1, times.size() - 1);
  const double w = (t - times[i - 1]) / (times[i] - times[i - 1]);
  return alphas[i - 1] + w * (alphas[i] - alphas[i - 1]);
}

// Unwrapped azimuths of poses about the axis of world_from_axis (for cameras with extrinsics ref_from_cam).
std::vector<double> azimuths(const std::vector<Rigid3d>& world_from_cam, const Rigid3d& world_from_axis,
                             const Rigid3d& ref_from_cam) {
  std::vector<double> alpha;
  for (const Rigid3d& pose : world_from_cam) {
    const Eigen::Matrix3d rotation =
        world_from_axis.linear().transpose() * pose.linear() * ref_from_cam.linear().transpose() * world_from_axis.linear();
    const double raw = tracking_init::twist_angle(rotation, Eigen::Vector3d::UnitZ());
    alpha.push_back(alpha.empty() ? raw : alpha.back() + wrap_pi(raw - alpha.back()));
  }
  return alpha;
}

bool finite(const Rigid3d& pose) { return pose.matrix().allFinite(); }

// track.log_iterations: Ceres' per-iteration summary as log lines, and its full report at the end
// (where a slow solve spends its time).
class IterationLogger : public ceres::IterationCallback {
 public:
  explicit IterationLogger(std::string origin) : origin_(std::move(origin)) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    log_info(fmt::format("{}: LM iteration {:3d} cost {:.6e} change {:+.3e} {} radius {:.2e} linear solver {:.2f} s, "
                         "iteration {:.2f} s", origin_, it.iteration, it.cost, -it.cost_change,
                         it.step_is_successful ? "accepted" : "rejected", it.trust_region_radius,
                         it.linear_solver_iterations > 0 ? it.step_solver_time_in_seconds : 0.0, it.iteration_time_in_seconds));
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::string origin_;
};

}  // namespace

TrackingResult track_with_frontend(const ScanIndex& scan, const FrontendResult& frontend, const TrackingOptions& options,
                                   const RigTrajectory* initial_guess) {
  options.check();
  const auto start = std::chrono::steady_clock::now();
  const int sensor_count = int(scan.rig.sensors.size());
  const int ref = scan.rig.reference_sensor;
  const std::string origin = scan.root.string();
  if (int(frontend.features.size()) != sensor_count)
    throw make_error(origin, "frontend", "front end result does not match the scan's sensors");
  if (scan.frames[ref].empty()) throw make_error(origin, scan.rig.sensors[ref].name, "the reference camera has no frames");
  const bool ba_only = options.mode == TrackingMode::kBaOnly;
  const bool use_regularisation = !ba_only && options.pose_regularisation;
  const bool use_velocity = use_regularisation && options.velocity_smoothness;  // Eq. 3 acts through the azimuths of Eq. 2
  std::vector<char> active(sensor_count, 0);
  for (int s = 0; s < sensor_count; ++s) {
    active[s] = (options.mode != TrackingMode::kSingleCamera || s == ref) && !scan.frames[s].empty();
    if (scan.frames[s].empty()) log_warn(origin + ": " + scan.rig.sensors[s].name + " has no frames; left out");
  }

  // --- Initialisation (tracking.h).
  int verified = 0;
  const std::vector<Rigid3d> odometry = tracking_init::chain_odometry(frontend, ref, &verified);
  if (scan.frames[ref].size() > 1 && verified == 0)
    throw make_error(origin, scan.rig.sensors[ref].name, "no verified frame pair in the reference camera (no features?)");
  const tracking_init::AxisEstimate axis0 = tracking_init::fit_axis(odometry);
  if (!axis0.from_rotation) log_warn(origin + ": too little rotation for an axis estimate; starting from the camera's up axis");
  const Rigid3d world_from_axis0 = axis_frame(axis0.point, axis0.direction, odometry[0]);
  std::vector<double> ref_times;
  for (const FrameEntry& e : scan.frames[ref]) ref_times.push_back(e.timestamp);
  const std::vector<double> ref_alpha0 = azimuths(odometry, world_from_axis0, Rigid3d::Identity());

  std::vector<std::vector<PoseBlock>> poses(sensor_count);
  std::vector<std::vector<double>> alpha(sensor_count);
  std::vector<PoseBlock> extrinsics(sensor_count);
  for (int s = 0; s < sensor_count; ++s) {
    extrinsics[s] = PoseBlock::from(scan.rig.sensors[s].ref_from_cam);
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      const double a = interpolate(ref_times, ref_alpha0, scan.frames[s][f].timestamp);
      const Rigid3d model = world_from_axis0 * axis_rotation(a) * world_from_axis0.inverse() * scan.rig.sensors[s].ref_from_cam;
      poses[s].push_back(PoseBlock::from(s == ref ? odometry[f] : model));
      alpha[s].push_back(s == ref ? ref_alpha0[f] : a);
    }
  }
  PoseBlock axis = PoseBlock::from(world_from_axis0);
  if (initial_guess) {  // start from the given poses, moved into the gauge (the first reference frame = identity)
    check_rig_trajectory(*initial_guess, scan, origin + " (initial guess)");
    const Rigid3d gauge = initial_guess->world_from_cam[ref].front().world_from_cam.inverse();
    const Rigid3d world_from_axis = gauge * initial_guess->world_from_axis;
    axis = PoseBlock::from(world_from_axis);
    for (int s = 0; s < sensor_count; ++s) {
      std::vector<Rigid3d> world_from_cam;
      for (const StampedPose& p : initial_guess->world_from_cam[s]) world_from_cam.push_back(gauge * p.world_from_cam);
      if (s != ref) extrinsics[s] = PoseBlock::from(initial_guess->ref_from_cam[s]);
      const std::vector<double> a = azimuths(world_from_cam, world_from_axis, initial_guess->ref_from_cam[s]);
      for (std::size_t f = 0; f < world_from_cam.size(); ++f) {
        poses[s][f] = PoseBlock::from(world_from_cam[f]);
        alpha[s][f] = a[f];
      }
    }
  }
  PoseBlock identity;
  // T_r (world_from_rig): the reference camera at alpha = 0 without its wobble (tracking.h). The
  // first reference frame is the world origin, so T_r starts at T_u R(alpha_ref0)^-1 T_u^-1 (the
  // identity for the standard initialisation, where alpha_ref0 = 0).
  PoseBlock rig = PoseBlock::from(axis.pose() * axis_rotation(-alpha[ref][0]) * axis.pose().inverse());

  // Landmarks restricted to the active sensors, initialised from their first observation.
  std::vector<std::vector<Observation>> tracks;
  std::vector<std::array<double, 3>> landmarks;
  std::vector<std::vector<int>> observation_count(sensor_count);
  for (int s = 0; s < sensor_count; ++s) observation_count[s].assign(scan.frames[s].size(), 0);
  for (const auto& track : frontend.landmarks) {
    std::vector<Observation> kept;
    for (const Observation& o : track)
      if (active[o.sensor]) kept.push_back(o);
    if (kept.size() < 2) continue;
    const Observation& first = kept.front();
    const Keypoint& kp = frontend.features[first.sensor][first.frame].keypoints[first.keypoint];
    const Eigen::Vector3d point =
        poses[first.sensor][first.frame].pose() * scan.rig.sensors[first.sensor].intrinsics.backproject(kp.u, kp.v, kp.depth);
    landmarks.push_back({point.x(), point.y(), point.z()});
    for (const Observation& o : kept) ++observation_count[o.sensor][o.frame];
    tracks.push_back(std::move(kept));
  }
  const auto init_done = std::chrono::steady_clock::now();

  // --- The factor graph (Eq. 4: sum of Eq. 3, Eq. 2 and Huber(Eq. 1)).
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto quaternion_manifold = std::make_unique<ceres::QuaternionManifold>();
  auto huber = std::make_unique<ceres::HuberLoss>(options.huber_delta);
  TrackingStats stats;
  stats.mode = to_string(options.mode);
  // The residual blocks of each kind of factor, for the cost of each term (stats).
  enum FactorKind { kObservation, kRegularisation, kVelocity, kPriors, kSharedWobble, kFactorKinds };
  std::array<std::vector<ceres::ResidualBlockId>, kFactorKinds> factor_blocks;
  auto term_costs = [&](std::array<double, kFactorKinds>& out) {
    for (int k = 0; k < kFactorKinds; ++k) {
      out[k] = 0;
      if (factor_blocks[k].empty()) continue;
      ceres::Problem::EvaluateOptions evaluate;
      evaluate.residual_blocks = factor_blocks[k];
      evaluate.num_threads = 1;
      problem.Evaluate(evaluate, &out[k], nullptr, nullptr, nullptr);
    }
  };

  // Eq. 1: landmark observations.
  for (std::size_t j = 0; j < tracks.size(); ++j)
    for (const Observation& o : tracks[j]) {
      const Keypoint& kp = frontend.features[o.sensor][o.frame].keypoints[o.keypoint];
      const PinholeIntrinsics& in = scan.rig.sensors[o.sensor].intrinsics;
      const double sigma_px = std::pow(options.frontend.orb_scale_factor, kp.octave);
      const double sigma_d = options.depth_noise_coefficient * double(kp.depth) * kp.depth;
      factor_blocks[kObservation].push_back(problem.AddResidualBlock(
          tf::ObservationCost::create(kp.u, kp.v, kp.depth, in.fx, in.fy, in.cx, in.cy, sigma_px, sigma_d), huber.get(),
          poses[o.sensor][o.frame].q, poses[o.sensor][o.frame].t, landmarks[j].data()));
      ++stats.observations;
    }

  // Eq. 2: pose regularisation of every frame of the active cameras.
  const double sigma_t = options.reg_translation_std_m, sigma_r = deg2rad(options.reg_rotation_std_deg);
  if (use_regularisation) {
    for (int s = 0; s < sensor_count; ++s) {
      if (!active[s]) continue;
      PoseBlock& cam = s == ref ? identity : extrinsics[s];
      for (std::size_t f = 0; f < poses[s].size(); ++f)
        factor_blocks[kRegularisation].push_back(problem.AddResidualBlock(tf::RegularisationCost::create(sigma_t, sigma_r), nullptr,
                                                                   poses[s][f].q, poses[s][f].t, &alpha[s][f], axis.q,
                                                                   axis.t, rig.q, rig.t, cam.q, cam.t));
    }
    factor_blocks[kPriors].push_back(problem.AddResidualBlock(tf::PosePriorCost::create(axis.q, axis.t, 1.0, 1.0), nullptr, axis.q, axis.t));
    // The calibration as a prior on T_c (see tracking.h).
    for (int s = 0; s < sensor_count; ++s)
      if (s != ref && active[s] && options.mode != TrackingMode::kFixedExtrinsics)
        factor_blocks[kPriors].push_back(problem.AddResidualBlock(
            tf::PosePriorCost::create(extrinsics[s].q, extrinsics[s].t, options.extrinsics_prior_translation_std_m,
                                      deg2rad(options.extrinsics_prior_rotation_std_deg)),
            nullptr, extrinsics[s].q, extrinsics[s].t));
    // ... and, held firmly, along the two directions nothing else observes (tracking.h).
    if (options.extrinsics_null_prior)
      for (int s = 0; s < sensor_count; ++s)
        if (s != ref && active[s] && options.mode != TrackingMode::kFixedExtrinsics)
          factor_blocks[kPriors].push_back(problem.AddResidualBlock(
              tf::ExtrinsicsNullPriorCost::create(extrinsics[s].q, extrinsics[s].t, 1e-4, deg2rad(0.01)), nullptr,
              extrinsics[s].q, extrinsics[s].t, axis.q, rig.q));
  }

  // Every frame of the active cameras in timestamp order (ties by camera), for the factors that
  // link frames across cameras.
  struct Node { double t; int s, f; };
  std::vector<Node> nodes;
  for (int s = 0; s < sensor_count; ++s)
    if (active[s])
      for (std::size_t f = 0; f < poses[s].size(); ++f) nodes.push_back({scan.frames[s][f].timestamp, s, int(f)});
  std::sort(nodes.begin(), nodes.end(), [](const Node& a, const Node& b) { return a.t != b.t ? a.t < b.t : a.s < b.s; });

  // Shared wobble between consecutive frames of different cameras (tracking.h).
  if (use_regularisation && options.shared_wobble) {
    const double rate_r = deg2rad(options.wobble_rate_std_deg_s), rate_t = options.wobble_rate_std_m_s;
    constexpr double kFloorS = 1e-3;  // timestamp jitter
    for (std::size_t k = 0; k + 1 < nodes.size(); ++k) {
      const Node &a = nodes[k], &b = nodes[k + 1];
      const double dt = std::max(b.t - a.t, 0.0) + kFloorS;
      if (a.s == b.s || rate_r * dt >= sigma_r) continue;
      PoseBlock& extr_a = a.s == ref ? identity : extrinsics[a.s];
      PoseBlock& extr_b = b.s == ref ? identity : extrinsics[b.s];
      factor_blocks[kSharedWobble].push_back(problem.AddResidualBlock(
          tf::SharedWobbleCost::create(rate_t * dt, rate_r * dt), nullptr, poses[a.s][a.f].q, poses[a.s][a.f].t,
          &alpha[a.s][a.f], extr_a.q, extr_a.t, poses[b.s][b.f].q, poses[b.s][b.f].t, &alpha[b.s][b.f], extr_b.q,
          extr_b.t, axis.q, axis.t, rig.q, rig.t));
      ++stats.shared_wobble_links;
    }
  }

  // Eq. 3: velocity smoothness over all frames of all cameras in timestamp order.
  if (use_velocity) {
    std::vector<Node> instants;  // one representative per instant
    const double sigma_accel = deg2rad(options.angular_accel_std_deg_s2);
    for (const Node& n : nodes) {
      if (!instants.empty() && n.t - instants.back().t < options.same_time_s) {
        factor_blocks[kVelocity].push_back(problem.AddResidualBlock(
            tf::SameTimeCost::create(1e-6), nullptr, &alpha[instants.back().s][instants.back().f], &alpha[n.s][n.f]));
        continue;
      }
      instants.push_back(n);
    }
    for (std::size_t k = 1; k + 1 < instants.size(); ++k) {
      const Node &a = instants[k - 1], &b = instants[k], &c = instants[k + 1];
      const double sigma = sigma_accel * (options.velocity_std_scales_with_dt ? 0.5 * (c.t - a.t) : 1.0);
      factor_blocks[kVelocity].push_back(problem.AddResidualBlock(tf::VelocityCost::create(a.t, b.t, c.t, sigma), nullptr,
                                                                  &alpha[a.s][a.f], &alpha[b.s][b.f], &alpha[c.s][c.f]));
    }
  }

  // Manifolds, gauge and constant blocks.
  for (int s = 0; s < sensor_count; ++s) {
    for (std::size_t f = 0; f < poses[s].size(); ++f) {
      if (!problem.HasParameterBlock(poses[s][f].q)) continue;
      problem.SetManifold(poses[s][f].q, quaternion_manifold.get());
      // Gauge: the first reference frame. Without Eq. 2 (ba-only) also the first frame of every camera (without
      // cross-camera landmarks each camera's bundle adjustment has its own gauge; it stays at the
      // calibrated extrinsics) and frames without observations (no factor constrains them).
      const bool unconstrained = !use_regularisation && (observation_count[s][f] == 0 || f == 0);
      if ((s == ref && f == 0) || unconstrained) {
        problem.SetParameterBlockConstant(poses[s][f].q);
        problem.SetParameterBlockConstant(poses[s][f].t);
      }
    }
    if (s != ref && problem.HasParameterBlock(extrinsics[s].q)) {
      problem.SetManifold(extrinsics[s].q, quaternion_manifold.get());
      if (options.mode == TrackingMode::kFixedExtrinsics) {
        problem.SetParameterBlockConstant(extrinsics[s].q);
        problem.SetParameterBlockConstant(extrinsics[s].t);
      }
    }
    if (active[s])
      for (int count : observation_count[s]) stats.frames_without_observations += count == 0;
    if (active[s]) stats.frames += int(poses[s].size());
  }
  if (problem.HasParameterBlock(identity.q)) {
    problem.SetParameterBlockConstant(identity.q);
    problem.SetParameterBlockConstant(identity.t);
  }
  if (problem.HasParameterBlock(axis.q)) problem.SetManifold(axis.q, quaternion_manifold.get());
  if (problem.HasParameterBlock(rig.q)) {
    problem.SetManifold(rig.q, quaternion_manifold.get());
    // Gauge of T_r: a rotation of T_r about the axis is a shift of every azimuth; the first
    // reference azimuth is held instead.
    problem.SetParameterBlockConstant(&alpha[ref][0]);
  }
  // A frame of an active camera outside every factor (ba-only without observations) keeps its start.

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type =
      options.linear_solver == "sparse_schur" ? ceres::SPARSE_SCHUR : ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.threads > 0 ? options.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.logging_type = ceres::SILENT;
  // No explicit ParameterBlockOrdering: Ceres orders the blocks of a user ordering by address, which
  // varies between runs (measured: about 25% faster but not reproducible); its automatic ordering
  // finds the landmarks as the eliminated set and is reproducible.
  IterationLogger iteration_logger(origin);
  if (options.log_iterations) solver_options.callbacks.push_back(&iteration_logger);
  ceres::Solver::Summary summary;
  if (problem.NumResidualBlocks() > 0) {
    term_costs(stats.initial_term_costs);
    ceres::Solve(solver_options, &problem, &summary);
    term_costs(stats.final_term_costs);
    if (options.log_iterations) log_info(summary.FullReport());
  }
  const auto solve_done = std::chrono::steady_clock::now();

  // --- Outputs.
  TrackingResult result;
  RigTrajectory& trajectory = result.trajectory;
  trajectory.source = std::string("tracked:") + to_string(options.mode);
  trajectory.world_from_cam.resize(sensor_count);
  trajectory.ref_from_cam.resize(sensor_count);
  for (int s = 0; s < sensor_count; ++s)
    trajectory.ref_from_cam[s] = (s != ref && active[s] && problem.HasParameterBlock(extrinsics[s].q))
                                     ? extrinsics[s].pose()
                                     : (s == ref ? Rigid3d::Identity() : scan.rig.sensors[s].ref_from_cam);
  std::vector<Rigid3d> ref_poses;
  for (const PoseBlock& p : poses[ref]) ref_poses.push_back(p.pose());
  Rigid3d world_from_axis;
  if (use_regularisation) {
    world_from_axis = axis.pose();
  } else {
    const tracking_init::AxisEstimate fitted = tracking_init::fit_axis(ref_poses);
    world_from_axis = axis_frame(fitted.point, fitted.direction, ref_poses[0]);
  }
  trajectory.world_from_axis =
      axis_frame(world_from_axis.translation(), world_from_axis.linear().col(2), ref_poses[0]);
  const std::vector<double> ref_alpha = azimuths(ref_poses, trajectory.world_from_axis, Rigid3d::Identity());
  bool all_finite = finite(trajectory.world_from_axis);
  result.azimuth_rad.resize(sensor_count);
  for (int s = 0; s < sensor_count; ++s) {
    std::vector<Rigid3d> world_from_cam;
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      Rigid3d pose;
      if (active[s]) {
        pose = poses[s][f].pose();
      } else if (use_regularisation) {  // single-camera mode: the other cameras follow the Eq. 2 model
        const double a = interpolate(ref_times, alpha[ref], scan.frames[s][f].timestamp);
        pose = axis.pose() * axis_rotation(a) * axis.pose().inverse() * rig.pose() * trajectory.ref_from_cam[s];
      } else {  // ... or, without Eq. 2, the rotation about the fitted axis
        const double a = interpolate(ref_times, ref_alpha, scan.frames[s][f].timestamp);
        pose = trajectory.world_from_axis * axis_rotation(a) * trajectory.world_from_axis.inverse() * trajectory.ref_from_cam[s];
      }
      all_finite = all_finite && finite(pose);
      trajectory.world_from_cam[s].push_back({scan.frames[s][f].timestamp, pose});
      world_from_cam.push_back(pose);
    }
    for (double a : azimuths(world_from_cam, trajectory.world_from_axis, trajectory.ref_from_cam[s]))
      result.azimuth_rad[s].push_back(wrap_two_pi(a));
  }

  stats.landmarks = int(tracks.size());
  stats.residual_blocks = problem.NumResidualBlocks();
  stats.parameters = problem.NumParameters();
  stats.iterations = int(summary.iterations.size()) - 1;
  stats.initial_cost = summary.initial_cost;
  stats.final_cost = summary.final_cost;
  stats.converged = summary.termination_type == ceres::CONVERGENCE && all_finite;
  stats.termination = summary.message;
  stats.linear_solver = options.linear_solver;
  stats.threads = solver_options.num_threads;
  stats.frontend_seconds = frontend.total_seconds;
  stats.feature_ms_per_frame = frontend.feature_ms_per_frame;
  stats.matching_ms_per_frame = frontend.matching_ms_per_frame;
  stats.same_camera_pairs = frontend.same_camera_pairs;
  stats.cross_camera_pairs = frontend.cross_camera_pairs;
  stats.loop_pairs = frontend.loop_pairs;
  stats.frames_without_features = frontend.frames_without_features;
  stats.init_seconds = std::chrono::duration<double>(init_done - start).count();
  stats.solve_seconds = std::chrono::duration<double>(solve_done - init_done).count();
  stats.linear_solver_seconds = summary.linear_solver_time_in_seconds;
  stats.jacobian_seconds = summary.jacobian_evaluation_time_in_seconds;
  if (!stats.converged)
    log_warn(origin + ": tracking did not converge (" + summary.message + (all_finite ? "" : "; non-finite poses") + ")");
  result.stats = stats;
  return result;
}

TrackingResult track_scan(const ScanIndex& scan, const TrackingOptions& options) {
  options.check();
  FrontendOptions frontend_options = options.frontend;
  frontend_options.threads = options.threads;
  frontend_options.depth_noise_coefficient = options.depth_noise_coefficient;
  if (options.mode == TrackingMode::kSingleCamera) frontend_options.sensors = {scan.rig.reference_sensor};
  const FrontendResult frontend = run_frontend(scan, frontend_options);
  log_info("front end: " + std::to_string(frontend.landmarks.size()) + " landmarks, " +
           std::to_string(frontend.same_camera_pairs) + " same-camera, " + std::to_string(frontend.cross_camera_pairs) +
           " cross-camera, " + std::to_string(frontend.loop_pairs) + " loop pairs");
  return track_with_frontend(scan, frontend, options);
}

std::string tracking_stats_json(const TrackingStats& s) {
  nlohmann::json j = {{"format", "panoscan-tracking-stats"},
                      {"version", 1},
                      {"mode", s.mode},
                      {"frames", s.frames},
                      {"landmarks", s.landmarks},
                      {"observations", s.observations},
                      {"frames_without_observations", s.frames_without_observations},
                      {"frames_without_features", s.frames_without_features},
                      {"pairs", {{"same_camera", s.same_camera_pairs}, {"cross_camera", s.cross_camera_pairs}, {"loop", s.loop_pairs}}},
                      {"residual_blocks", s.residual_blocks},
                      {"parameters", s.parameters},
                      {"iterations", s.iterations},
                      {"initial_cost", s.initial_cost},
                      {"final_cost", s.final_cost},
                      {"term_costs", {{"order", {"observation", "regularisation", "velocity", "priors", "shared_wobble"}},
                                      {"initial", s.initial_term_costs}, {"final", s.final_term_costs}}},
                      {"shared_wobble_links", s.shared_wobble_links},
                      {"converged", s.converged},
                      {"termination", s.termination},
                      {"linear_solver", s.linear_solver},
                      {"threads", s.threads},
                      {"seconds", {{"frontend", s.frontend_seconds}, {"init", s.init_seconds}, {"solve", s.solve_seconds},
                                   {"linear_solver", s.linear_solver_seconds}, {"jacobians", s.jacobian_seconds}}},
                      {"frontend_ms_per_frame", {{"features", s.feature_ms_per_frame}, {"matching", s.matching_ms_per_frame}}}};
  return j.dump(2) + "\n";
}

void write_tracking_result(const std::filesystem::path& dir, const TrackingResult& result, const RigInfo& rig) {
  std::filesystem::create_directories(dir);
  write_rig_trajectory(dir, result.trajectory, rig);
  write_file_atomic(dir / "tracking_stats.json", tracking_stats_json(result.stats));
}

}  // namespace panoscan
