// The steps of the joint tracking (tracking_graph.h); the choices are documented in tracking.h.
//
// Solver: Levenberg-Marquardt with SPARSE_SCHUR by default: the landmarks (3 parameters each, the
// large majority) form an independent set that Ceres eliminates first (its automatic ordering), and
// the reduced camera system over poses, azimuths, T_u and T_c is sparse (banded by Eq. 3 and the
// frame-to-frame tracks) and factored by SuiteSparse/CHOLMOD. SPARSE_NORMAL_CHOLESKY is the option
// for graphs with few landmarks. Residuals and Jacobians are evaluated on `threads` threads.
#include "tracking_graph.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <thread>
#include <unordered_map>

#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/error.h"
#include "panoscan/core/log.h"
#include "panoscan/core/trajectory.h"
#include "depth_odometry.h"
#include "tracking_factors.h"
#include "tracking_init.h"

namespace panoscan::tracking_graph {

namespace tf = tracking_factors;

PoseBlock PoseBlock::from(const Rigid3d& pose) {
  PoseBlock block;
  const Eigen::Quaterniond q(pose.linear());
  block.q[0] = q.w();
  block.q[1] = q.x();
  block.q[2] = q.y();
  block.q[3] = q.z();
  for (int k = 0; k < 3; ++k) block.t[k] = pose.translation()[k];
  return block;
}

Rigid3d PoseBlock::pose() const {
  return make_rigid(Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
}

namespace {

Rigid3d axis_rotation(double alpha) { return rotation_about(Eigen::Vector3d::UnitZ(), alpha); }

// Piecewise-linear azimuth of time through (times, alphas) (sorted), extrapolated with the end slopes.
double interpolate(const std::vector<double>& times, const std::vector<double>& alphas, double t) {
  if (times.size() == 1) return alphas[0];
  std::size_t i = std::upper_bound(times.begin(), times.end(), t) - times.begin();
  i = std::clamp<std::size_t>(i, 1, times.size() - 1);
  const double w = (t - times[i - 1]) / (times[i] - times[i - 1]);
  return alphas[i - 1] + w * (alphas[i] - alphas[i - 1]);
}

bool finite(const Rigid3d& pose) { return pose.matrix().allFinite(); }

// The reference camera's pose at time t, interpolated between its frames (translation linear,
// rotation slerp) and held at the end poses outside them: where a handheld rig's other cameras start
// (and, in single-camera mode, where they stay) without a rotator model.
Rigid3d reference_pose_at(const std::vector<double>& times, const std::vector<Rigid3d>& poses, double t) {
  if (t <= times.front()) return poses.front();
  if (t >= times.back()) return poses.back();
  std::vector<StampedPose> stamped;
  const std::size_t i = std::upper_bound(times.begin(), times.end(), t) - times.begin();
  for (std::size_t k : {i - 1, i}) stamped.push_back({times[k], poses[k]});
  return *interpolate_trajectory(stamped, {t}, times[i] - times[i - 1]).front();
}

// track.log_iterations: Ceres' per-iteration summary as log lines, and its full report at the end
// (where a slow solve spends its time).
class IterationLogger : public ceres::IterationCallback {
 public:
  explicit IterationLogger(std::string origin) : origin_(std::move(origin)) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
    log_info(
        fmt::format("{}: LM iteration {:3d} cost {:.6e} change {:+.3e} {} radius {:.2e} linear solver {:.2f} s, "
                    "iteration {:.2f} s",
                    origin_, it.iteration, it.cost, -it.cost_change, it.step_is_successful ? "accepted" : "rejected",
                    it.trust_region_radius, it.linear_solver_iterations > 0 ? it.step_solver_time_in_seconds : 0.0,
                    it.iteration_time_in_seconds));
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::string origin_;
};

}  // namespace

std::vector<double> azimuths(const std::vector<Rigid3d>& world_from_cam, const Rigid3d& world_from_axis,
                             const Rigid3d& ref_from_cam) {
  std::vector<double> alpha;
  for (const Rigid3d& pose : world_from_cam) {
    const Eigen::Matrix3d rotation = world_from_axis.linear().transpose() * pose.linear() *
                                     ref_from_cam.linear().transpose() * world_from_axis.linear();
    const double raw = tracking_init::twist_angle(rotation, Eigen::Vector3d::UnitZ());
    alpha.push_back(alpha.empty() ? raw : alpha.back() + wrap_pi(raw - alpha.back()));
  }
  return alpha;
}

FactorGraph::FactorGraph() {
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem = std::make_unique<ceres::Problem>(problem_options);
  quaternion_manifold = std::make_unique<ceres::QuaternionManifold>();
}

std::array<double, kFactorKinds> FactorGraph::term_costs() const {
  std::array<double, kFactorKinds> out{};
  for (int k = 0; k < kFactorKinds; ++k) {
    if (blocks[k].empty()) continue;
    ceres::Problem::EvaluateOptions evaluate;
    evaluate.residual_blocks = blocks[k];
    evaluate.num_threads = 1;
    problem->Evaluate(evaluate, &out[k], nullptr, nullptr, nullptr);
  }
  return out;
}

TrackingState initialise_tracking_state(const ScanIndex& scan, const FrontendResult& frontend,
                                        const TrackingOptions& options, const RigTrajectory* initial_guess) {
  TrackingState st;
  st.sensor_count = int(scan.rig.sensors.size());
  st.ref = scan.rig.reference_sensor;
  st.origin = scan.root.string();
  const int ref = st.ref;
  if (int(frontend.features.size()) != st.sensor_count)
    throw make_error(st.origin, "frontend", "front end result does not match the scan's sensors");
  if (scan.frames[ref].empty())
    throw make_error(st.origin, scan.rig.sensors[ref].name, "the reference camera has no frames");
  const bool ba_only = options.mode == TrackingMode::kBaOnly;
  st.handheld = scan.rig.motion == RigMotion::kHandheld;
  if (st.handheld && (options.mode == TrackingMode::kFull || options.mode == TrackingMode::kFixedExtrinsics))
    throw make_error(st.origin + "/rig.json", "motion",
                     std::string("handheld: track.mode ") + to_string(options.mode) +
                         " models an in-place rotator (Eq. 2-3); use ba-only or single-camera");
  // Handheld: Eq. 1 alone (no rotator to regularise towards), in ba-only and single-camera mode.
  st.use_regularisation = !ba_only && !st.handheld && options.pose_regularisation;
  st.use_velocity = st.use_regularisation && options.velocity_smoothness;  // Eq. 3 acts through the azimuths of Eq. 2
  st.active.assign(st.sensor_count, 0);
  for (int s = 0; s < st.sensor_count; ++s) {
    st.active[s] = (options.mode != TrackingMode::kSingleCamera || s == ref) && !scan.frames[s].empty();
    if (scan.frames[s].empty()) log_warn(st.origin + ": " + scan.rig.sensors[s].name + " has no frames; left out");
  }

  // Odometry of the reference camera, a first axis, azimuths interpolated in time (tracking.h).
  int verified = 0;
  const std::vector<Rigid3d> odometry = tracking_init::chain_odometry(frontend, ref, &verified);
  if (scan.frames[ref].size() > 1 && verified == 0)
    throw make_error(st.origin, scan.rig.sensors[ref].name,
                     "no verified frame pair in the reference camera (no features?)");
  const tracking_init::AxisEstimate axis0 = tracking_init::fit_axis(odometry);
  if (!axis0.from_rotation && !st.handheld)
    log_warn(st.origin + ": too little rotation for an axis estimate; starting from the camera's up axis");
  const Rigid3d world_from_axis0 = axis_frame(axis0.point, axis0.direction, odometry[0]);
  for (const FrameEntry& e : scan.frames[ref]) st.ref_times.push_back(e.timestamp);
  const std::vector<double> ref_alpha0 = azimuths(odometry, world_from_axis0, Rigid3d::Identity());

  st.poses.resize(st.sensor_count);
  st.alpha.resize(st.sensor_count);
  st.extrinsics.resize(st.sensor_count);
  for (int s = 0; s < st.sensor_count; ++s) {
    st.extrinsics[s] = PoseBlock::from(scan.rig.sensors[s].ref_from_cam);
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      const double t = scan.frames[s][f].timestamp;
      const double a = interpolate(st.ref_times, ref_alpha0, t);
      const Rigid3d model =
          st.handheld
              ? reference_pose_at(st.ref_times, odometry, t) * scan.rig.sensors[s].ref_from_cam
              : world_from_axis0 * axis_rotation(a) * world_from_axis0.inverse() * scan.rig.sensors[s].ref_from_cam;
      st.poses[s].push_back(PoseBlock::from(s == ref ? odometry[f] : model));
      st.alpha[s].push_back(s == ref ? ref_alpha0[f] : a);
    }
  }
  st.axis = PoseBlock::from(world_from_axis0);
  if (initial_guess) {  // start from the given poses, moved into the gauge (the first reference frame = identity)
    check_rig_trajectory(*initial_guess, scan, st.origin + " (initial guess)");
    const Rigid3d gauge = initial_guess->world_from_cam[ref].front().world_from_cam.inverse();
    const Rigid3d world_from_axis = gauge * initial_guess->world_from_axis;
    st.axis = PoseBlock::from(world_from_axis);
    for (int s = 0; s < st.sensor_count; ++s) {
      std::vector<Rigid3d> world_from_cam;
      for (const StampedPose& p : initial_guess->world_from_cam[s]) world_from_cam.push_back(gauge * p.world_from_cam);
      if (s != ref) st.extrinsics[s] = PoseBlock::from(initial_guess->ref_from_cam[s]);
      const std::vector<double> a = azimuths(world_from_cam, world_from_axis, initial_guess->ref_from_cam[s]);
      for (std::size_t f = 0; f < world_from_cam.size(); ++f) {
        st.poses[s][f] = PoseBlock::from(world_from_cam[f]);
        st.alpha[s][f] = a[f];
      }
    }
  }
  // T_r (world_from_rig): the reference camera at alpha = 0 without its wobble (tracking.h). The
  // first reference frame is the world origin, so T_r starts at T_u R(alpha_ref0)^-1 T_u^-1 (the
  // identity for the standard initialisation, where alpha_ref0 = 0).
  st.rig = PoseBlock::from(st.axis.pose() * axis_rotation(-st.alpha[ref][0]) * st.axis.pose().inverse());

  // Landmarks restricted to the active sensors, initialised from their first observation.
  st.observation_count.resize(st.sensor_count);
  for (int s = 0; s < st.sensor_count; ++s) st.observation_count[s].assign(scan.frames[s].size(), 0);
  for (const auto& track : frontend.landmarks) {
    std::vector<Observation> kept;
    for (const Observation& o : track)
      if (st.active[o.sensor]) kept.push_back(o);
    if (kept.size() < 2) continue;
    const Observation& first = kept.front();
    const Keypoint& kp = frontend.features[first.sensor][first.frame].keypoints[first.keypoint];
    const Eigen::Vector3d point = st.poses[first.sensor][first.frame].pose() *
                                  scan.rig.sensors[first.sensor].intrinsics.backproject(kp.u, kp.v, kp.depth);
    st.landmarks.push_back({point.x(), point.y(), point.z()});
    for (const Observation& o : kept) ++st.observation_count[o.sensor][o.frame];
    st.tracks.push_back(std::move(kept));
  }
  // Which extrinsics the cross-camera landmarks observe (TrackingState::extrinsics_observed).
  std::vector<std::vector<int>> shared(st.sensor_count, std::vector<int>(st.sensor_count, 0));
  for (const auto& track : st.tracks) {
    std::vector<char> sees(st.sensor_count, 0);
    for (const Observation& o : track) sees[o.sensor] = 1;
    for (int s = 0; s < st.sensor_count; ++s)
      for (int t = 0; t < st.sensor_count; ++t)
        if (s != t && sees[s] && sees[t]) ++shared[s][t];
  }
  st.extrinsics_observed.assign(st.sensor_count, 0);
  st.extrinsics_observed[ref] = 1;
  for (bool grew = true; grew;) {
    grew = false;
    for (int s = 0; s < st.sensor_count; ++s)
      for (int t = 0; t < st.sensor_count && !st.extrinsics_observed[s]; ++t)
        if (st.extrinsics_observed[t] && shared[s][t] >= options.extrinsics_release_min_landmarks) {
          st.extrinsics_observed[s] = 1;
          grew = true;
        }
  }

  for (int s = 0; s < st.sensor_count; ++s)
    if (st.active[s])
      for (std::size_t f = 0; f < st.poses[s].size(); ++f) st.nodes.push_back({scan.frames[s][f].timestamp, s, int(f)});
  std::sort(st.nodes.begin(), st.nodes.end(),
            [](const FrameNode& a, const FrameNode& b) { return a.t != b.t ? a.t < b.t : a.s < b.s; });
  return st;
}

void add_observation_factors(FactorGraph& graph, TrackingState& st, const ScanIndex& scan,
                             const FrontendResult& frontend, const TrackingOptions& options) {
  graph.huber = std::make_unique<ceres::HuberLoss>(options.huber_delta);
  for (std::size_t j = 0; j < st.tracks.size(); ++j)
    for (const Observation& o : st.tracks[j]) {
      const Keypoint& kp = frontend.features[o.sensor][o.frame].keypoints[o.keypoint];
      const PinholeIntrinsics& in = scan.rig.sensors[o.sensor].intrinsics;
      const double sigma_px = std::pow(options.frontend.orb_scale_factor, kp.octave);
      const double sigma_d = options.depth_noise_coefficient * double(kp.depth) * kp.depth;
      graph.blocks[kObservation].push_back(graph.problem->AddResidualBlock(
          tf::ObservationCost::create(kp.u, kp.v, kp.depth, in.fx, in.fy, in.cx, in.cy, sigma_px, sigma_d),
          graph.huber.get(), st.poses[o.sensor][o.frame].q, st.poses[o.sensor][o.frame].t, st.landmarks[j].data()));
    }
}

void add_regularisation_factors(FactorGraph& graph, TrackingState& st, const TrackingOptions& options) {
  if (!st.use_regularisation) return;
  ceres::Problem& problem = *graph.problem;
  const double sigma_t = options.reg_translation_std_m, sigma_r = deg2rad(options.reg_rotation_std_deg);
  for (int s = 0; s < st.sensor_count; ++s) {
    if (!st.active[s]) continue;
    PoseBlock& cam = s == st.ref ? st.identity : st.extrinsics[s];
    for (std::size_t f = 0; f < st.poses[s].size(); ++f)
      graph.blocks[kRegularisation].push_back(problem.AddResidualBlock(
          tf::RegularisationCost::create(sigma_t, sigma_r), nullptr, st.poses[s][f].q, st.poses[s][f].t,
          &st.alpha[s][f], st.axis.q, st.axis.t, st.rig.q, st.rig.t, cam.q, cam.t));
  }
  graph.blocks[kPriors].push_back(problem.AddResidualBlock(tf::PosePriorCost::create(st.axis.q, st.axis.t, 1.0, 1.0),
                                                           nullptr, st.axis.q, st.axis.t));
  const bool refine_extrinsics = options.mode != TrackingMode::kFixedExtrinsics;
  // The calibration as a prior on T_c (see tracking.h).
  for (int s = 0; s < st.sensor_count; ++s)
    if (s != st.ref && st.active[s] && refine_extrinsics)
      graph.blocks[kPriors].push_back(problem.AddResidualBlock(
          tf::PosePriorCost::create(st.extrinsics[s].q, st.extrinsics[s].t, options.extrinsics_prior_translation_std_m,
                                    deg2rad(options.extrinsics_prior_rotation_std_deg)),
          nullptr, st.extrinsics[s].q, st.extrinsics[s].t));
  // ... and, held firmly, along the two directions nothing else observes (tracking.h), unless the
  // cross-camera landmarks observe them; with hold_extrinsics_slide they release the rotation only.
  if (options.extrinsics_null_prior)
    for (int s = 0; s < st.sensor_count; ++s) {
      if (s == st.ref || !st.active[s] || !refine_extrinsics) continue;
      if (st.extrinsics_observed[s] && !options.hold_extrinsics_slide) continue;
      const double sigma_r = st.extrinsics_observed[s] ? 0.0 : deg2rad(0.01);
      graph.blocks[kPriors].push_back(problem.AddResidualBlock(
          tf::ExtrinsicsNullPriorCost::create(st.extrinsics[s].q, st.extrinsics[s].t, 1e-4, sigma_r), nullptr,
          st.extrinsics[s].q, st.extrinsics[s].t, st.axis.q, st.rig.q));
    }
}

void add_shared_wobble_factors(FactorGraph& graph, TrackingState& st, const TrackingOptions& options) {
  if (!st.use_regularisation || !options.shared_wobble) return;
  const double sigma_r = deg2rad(options.reg_rotation_std_deg);
  const double rate_r = deg2rad(options.wobble_rate_std_deg_s), rate_t = options.wobble_rate_std_m_s;
  constexpr double kFloorS = 1e-3;  // timestamp jitter
  for (std::size_t k = 0; k + 1 < st.nodes.size(); ++k) {
    const FrameNode &a = st.nodes[k], &b = st.nodes[k + 1];
    const double dt = std::max(b.t - a.t, 0.0) + kFloorS;
    if (a.s == b.s || rate_r * dt >= sigma_r) continue;
    PoseBlock& extr_a = a.s == st.ref ? st.identity : st.extrinsics[a.s];
    PoseBlock& extr_b = b.s == st.ref ? st.identity : st.extrinsics[b.s];
    graph.blocks[kSharedWobble].push_back(graph.problem->AddResidualBlock(
        tf::SharedWobbleCost::create(rate_t * dt, rate_r * dt), nullptr, st.poses[a.s][a.f].q, st.poses[a.s][a.f].t,
        &st.alpha[a.s][a.f], extr_a.q, extr_a.t, st.poses[b.s][b.f].q, st.poses[b.s][b.f].t, &st.alpha[b.s][b.f],
        extr_b.q, extr_b.t, st.axis.q, st.axis.t, st.rig.q, st.rig.t));
    ++graph.shared_wobble_links;
  }
}

void add_velocity_factors(FactorGraph& graph, TrackingState& st, const TrackingOptions& options) {
  if (!st.use_velocity) return;
  std::vector<FrameNode> instants;  // one representative per instant
  const double sigma_accel = deg2rad(options.angular_accel_std_deg_s2);
  for (const FrameNode& n : st.nodes) {
    if (!instants.empty() && n.t - instants.back().t < options.same_time_s) {
      graph.blocks[kVelocity].push_back(graph.problem->AddResidualBlock(tf::SameTimeCost::create(1e-6), nullptr,
                                                                        &st.alpha[instants.back().s][instants.back().f],
                                                                        &st.alpha[n.s][n.f]));
      continue;
    }
    instants.push_back(n);
  }
  for (std::size_t k = 1; k + 1 < instants.size(); ++k) {
    const FrameNode &a = instants[k - 1], &b = instants[k], &c = instants[k + 1];
    const double sigma = sigma_accel * (options.velocity_std_scales_with_dt ? 0.5 * (c.t - a.t) : 1.0);
    graph.blocks[kVelocity].push_back(graph.problem->AddResidualBlock(tf::VelocityCost::create(a.t, b.t, c.t, sigma),
                                                                      nullptr, &st.alpha[a.s][a.f], &st.alpha[b.s][b.f],
                                                                      &st.alpha[c.s][c.f]));
  }
}

namespace {

// The standard deviation (deg) of the turn about the rig's axis that a depth-odometry pair measures:
// its information (omega, v) in frame b's coordinates, the axis (world_from_axis's z) seen from b,
// and the marginal variance of the rotation about it, every other direction free. Directions the
// pair does not observe carry no information; a ridge of 1e-9 of the trace keeps the inverse finite,
// so a turn coupled to them comes out huge, as it should.
double turn_std_deg(const Eigen::Matrix<double, 6, 6>& information, const Rigid3d& world_from_b,
                    const Rigid3d& world_from_axis) {
  const double trace = information.trace();
  if (!(trace > 0) || !std::isfinite(trace)) return std::numeric_limits<double>::infinity();
  const Eigen::Vector3d axis_in_b = world_from_b.linear().transpose() * world_from_axis.linear().col(2);
  Eigen::Matrix<double, 6, 6> regularised = information;
  regularised.diagonal().array() += 1e-9 * trace;
  const Eigen::Matrix<double, 6, 6> covariance = regularised.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
  const double variance = axis_in_b.dot(covariance.topLeftCorner<3, 3>() * axis_in_b);
  return variance > 0 ? rad2deg(std::sqrt(variance)) : std::numeric_limits<double>::infinity();
}

}  // namespace

void add_depth_odometry_factors(FactorGraph& graph, TrackingState& st, const ScanIndex& scan,
                                const FrontendResult& frontend, const TrackingOptions& options) {
  if (!options.depth_odometry || options.mode == TrackingMode::kBaOnly) return;
  struct PairTask {
    int s = 0, f = 0;
  };
  std::vector<PairTask> tasks;
  for (int s = 0; s < st.sensor_count; ++s)
    if (st.active[s])
      for (int f = 0; f + 1 < int(st.poses[s].size()); ++f) tasks.push_back({s, f});
  // The front end's grids, or (a front end run without them) grids from the depth images.
  const int block = options.depth_odometry_block_px;
  bool have_grids = int(frontend.depth_grids.size()) == st.sensor_count;
  for (int s = 0; s < st.sensor_count && have_grids; ++s)
    if (st.active[s]) {
      have_grids = frontend.depth_grids[s].size() == st.poses[s].size();
      for (const DepthGrid& grid : frontend.depth_grids[s]) have_grids = have_grids && grid.block == block;
    }
  std::vector<std::vector<DepthGrid>> read_grids;
  if (!have_grids) {
    read_grids.resize(st.sensor_count);
    std::vector<PairTask> frames;
    for (int s = 0; s < st.sensor_count; ++s) {
      if (st.active[s]) read_grids[s].resize(st.poses[s].size());
      for (int f = 0; f < int(read_grids[s].size()); ++f) frames.push_back({s, f});
    }
    tbb::parallel_for(std::size_t(0), frames.size(), [&](std::size_t k) {
      const auto [s, f] = frames[k];
      read_grids[s][f] = make_depth_grid(load_frame(scan, s, std::size_t(f)).depth, scan.rig.sensors[s].intrinsics,
                                         block, options.depth_noise_coefficient);
    });
  }
  const auto& grids = have_grids ? frontend.depth_grids : read_grids;
  depth_odometry::AlignOptions align;
  align.depth_noise_coefficient = options.depth_noise_coefficient;
  align.max_distance_m = options.depth_odometry_max_distance_m;
  align.min_overlap = options.depth_odometry_min_overlap;
  align.information_scale = options.depth_odometry_information_scale;
  align.huber_delta = options.huber_delta;
  st.depth_yaw_std_deg.assign(std::size_t(st.sensor_count), {});
  for (int s = 0; s < st.sensor_count; ++s)
    st.depth_yaw_std_deg[std::size_t(s)].assign(st.poses[s].size(), std::numeric_limits<double>::infinity());
  std::vector<depth_odometry::AlignResult> aligned(tasks.size());
  tbb::parallel_for(std::size_t(0), tasks.size(), [&](std::size_t k) {
    const auto [s, f] = tasks[k];
    const Rigid3d world_from_b = st.poses[s][f + 1].pose();
    const Rigid3d guess = st.poses[s][f].pose().inverse() * world_from_b;
    // On the rotator the guess's error is mostly a turn about the axis: the ICP turns b about it
    // first (depth_odometry.h).
    depth_odometry::TurnAxis turn;
    if (!st.handheld) {
      const Rigid3d b_from_axis = world_from_b.inverse() * st.axis.pose();
      turn.point = b_from_axis.translation();
      turn.direction = b_from_axis.linear().col(2);
    }
    aligned[k] =
        depth_odometry::align_depth_grids(grids[s][f], grids[s][f + 1], guess, align, st.handheld ? nullptr : &turn);
  });
  graph.depth_huber = std::make_unique<ceres::HuberLoss>(kDepthOdometryHuber);
  for (std::size_t k = 0; k < tasks.size(); ++k) {
    graph.depth_icp_iterations += aligned[k].iterations;
    if (!aligned[k].ok) {
      ++graph.depth_pairs_rejected;
      continue;
    }
    const auto [s, f] = tasks[k];
    st.depth_yaw_std_deg[std::size_t(s)][std::size_t(f)] =
        turn_std_deg(aligned[k].information, st.poses[s][f + 1].pose(), st.axis.pose());
    const PoseBlock measured = PoseBlock::from(aligned[k].a_from_b);
    const Eigen::Matrix<double, 6, 6, Eigen::RowMajor> root = depth_odometry::information_sqrt(aligned[k].information);
    graph.blocks[kDepthOdometry].push_back(graph.problem->AddResidualBlock(
        tf::RelativePoseCost::create(measured.q, measured.t, root.data()), graph.depth_huber.get(), st.poses[s][f].q,
        st.poses[s][f].t, st.poses[s][f + 1].q, st.poses[s][f + 1].t));
    graph.depth_pair_frames.push_back({s, f});
    ++graph.depth_pairs;
  }
}

namespace {

// The block pattern of the reduced camera system (what remains once the landmarks, group 0 of
// `ordering`, are eliminated), over the blocks numbered by `other_index`: row a lists a and every
// block coupled to it, sorted. Two blocks are coupled when a factor joins them, or when factors join
// each of them to one landmark (eliminating the landmark couples them). Residual blocks come in
// insertion order, so the pattern is built the same way every time.
std::vector<std::vector<int>> reduced_system_coupling(const TrackingState& st, const ceres::Problem& problem,
                                                      const ceres::ParameterBlockOrdering& ordering,
                                                      const std::unordered_map<const double*, int>& other_index) {
  std::unordered_map<const double*, int> landmark_index;
  for (std::size_t j = 0; j < st.landmarks.size(); ++j) landmark_index.emplace(st.landmarks[j].data(), int(j));
  std::vector<std::vector<int>> cliques(st.landmarks.size());  // first the landmarks' blocks, then the factors'
  std::vector<ceres::ResidualBlockId> residuals;
  problem.GetResidualBlocks(&residuals);
  std::vector<double*> parameters;
  std::vector<int> members;
  for (const ceres::ResidualBlockId residual : residuals) {
    problem.GetParameterBlocksForResidualBlock(residual, &parameters);
    members.clear();
    int landmark = -1;
    for (double* block : parameters) {
      if (auto it = landmark_index.find(block); it != landmark_index.end() && ordering.IsMember(block)) {
        landmark = it->second;
      } else if (auto jt = other_index.find(block); jt != other_index.end()) {
        members.push_back(jt->second);
      }
    }
    if (landmark >= 0)
      cliques[std::size_t(landmark)].insert(cliques[std::size_t(landmark)].end(), members.begin(), members.end());
    else if (members.size() > 1)
      cliques.push_back(members);
  }
  // Many landmarks are seen by the same frames: each distinct set of coupled blocks once.
  for (std::vector<int>& clique : cliques) {
    std::sort(clique.begin(), clique.end());
    clique.erase(std::unique(clique.begin(), clique.end()), clique.end());
  }
  std::sort(cliques.begin(), cliques.end());
  cliques.erase(std::unique(cliques.begin(), cliques.end()), cliques.end());
  std::vector<std::vector<int>> coupled(other_index.size());
  for (std::size_t i = 0; i < coupled.size(); ++i) coupled[i].push_back(int(i));
  for (const std::vector<int>& clique : cliques)
    for (int a : clique) coupled[std::size_t(a)].insert(coupled[std::size_t(a)].end(), clique.begin(), clique.end());
  for (std::vector<int>& row : coupled) {
    std::sort(row.begin(), row.end());
    row.erase(std::unique(row.begin(), row.end()), row.end());
  }
  return coupled;
}

// Approximate minimum degree (Eigen's AMDOrdering) of a symmetric pattern given as sorted rows: the
// rows in the order to eliminate them.
std::vector<int> amd_order(const std::vector<std::vector<int>>& coupled) {
  const int n = int(coupled.size());
  std::vector<Eigen::Triplet<int>> pattern;
  for (int a = 0; a < n; ++a)
    for (int b : coupled[std::size_t(a)]) pattern.emplace_back(a, b, 1);
  Eigen::SparseMatrix<int> matrix(n, n);
  matrix.setFromTriplets(pattern.begin(), pattern.end());
  Eigen::AMDOrdering<int>::PermutationType elimination;
  Eigen::AMDOrdering<int>()(matrix, elimination);  // indices()[k]: the row eliminated k-th
  if (elimination.size() != n) throw Error("tracking: the AMD ordering lost blocks (internal error)");
  return std::vector<int>(elimination.indices().data(), elimination.indices().data() + n);
}

// The landmarks eliminated first (group 0), then every other block. Ceres' automatic ordering takes
// an independent set of the whole graph, which also picks up about half of the azimuth blocks (they
// share no factor with a landmark), so the eliminated blocks have two sizes and Ceres falls back to
// its dynamic-size Schur eliminator (56% of the solve's instructions on SO-1 640x480, n = 16); with
// exactly the landmarks it uses the <3,3,3> specialisation (the solve: 18.9e9 -> 13.0e9
// instructions, the same iterations and cost).
// The remaining blocks form the reduced camera system that the sparse Cholesky factorises. Ceres
// orders the blocks of one group by address, so one group for all of them would let CAMD reduce
// the fill but from an order that depends on where the allocator put the blocks (two solves of one
// scan differed). Instead this function computes the fill-reducing order itself: approximate minimum
// degree (Eigen's AMD) on the block graph of the reduced system, built in a fixed order (frames in
// time order, then T_c, T_u, T_r), and gives each block a group in that order, which Ceres keeps.
std::shared_ptr<ceres::ParameterBlockOrdering> landmarks_first_ordering(TrackingState& st, ceres::Problem& problem) {
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (auto& landmark : st.landmarks)
    if (problem.HasParameterBlock(landmark.data())) ordering->AddElementToGroup(landmark.data(), 0);
  if (ordering->NumElements() == 0) return nullptr;  // nothing to eliminate: Ceres' own choice

  // The other blocks in the fixed order.
  std::vector<double*> others;
  std::unordered_map<const double*, int> other_index;
  auto add = [&](double* block) {
    if (!problem.HasParameterBlock(block) || ordering->IsMember(block) || other_index.count(block)) return;
    other_index.emplace(block, int(others.size()));
    others.push_back(block);
  };
  for (const FrameNode& node : st.nodes) {
    add(st.poses[node.s][node.f].q);
    add(st.poses[node.s][node.f].t);
    add(&st.alpha[node.s][node.f]);
  }
  for (PoseBlock& block : st.extrinsics) {
    add(block.q);
    add(block.t);
  }
  for (PoseBlock* block : {&st.identity, &st.axis, &st.rig}) {
    add(block->q);
    add(block->t);
  }
  std::vector<double*> all;  // anything else, in the problem's (insertion) order
  problem.GetParameterBlocks(&all);
  for (double* block : all) add(block);

  const std::vector<int> elimination = amd_order(reduced_system_coupling(st, problem, *ordering, other_index));
  for (std::size_t k = 0; k < elimination.size(); ++k)
    ordering->AddElementToGroup(others[std::size_t(elimination[k])], 1 + int(k));
  return ordering;
}

}  // namespace

int gauge_frame(const TrackingState& st) {
  if (!st.use_regularisation) return 0;
  const std::vector<int>& counts = st.observation_count[std::size_t(st.ref)];
  const auto observed = std::find_if(counts.begin(), counts.end(), [](int count) { return count > 0; });
  return observed == counts.end() ? 0 : int(observed - counts.begin());
}

void fix_gauge(FactorGraph& graph, TrackingState& st, const TrackingOptions& options) {
  ceres::Problem& problem = *graph.problem;
  const int gauge = gauge_frame(st);
  for (int s = 0; s < st.sensor_count; ++s) {
    for (std::size_t f = 0; f < st.poses[s].size(); ++f) {
      if (!problem.HasParameterBlock(st.poses[s][f].q)) continue;
      problem.SetManifold(st.poses[s][f].q, graph.quaternion_manifold.get());
      // Gauge: gauge_frame's reference frame (tracking_graph.h). Without Eq. 2 (ba-only) also the first frame of
      // every camera (without cross-camera landmarks each camera's bundle adjustment has its own gauge; it stays
      // at the calibrated extrinsics) and frames without observations (no factor constrains them).
      const bool unconstrained = !st.use_regularisation && (st.observation_count[s][f] == 0 || f == 0);
      if ((s == st.ref && int(f) == gauge) || unconstrained) {
        problem.SetParameterBlockConstant(st.poses[s][f].q);
        problem.SetParameterBlockConstant(st.poses[s][f].t);
      }
    }
    if (s != st.ref && problem.HasParameterBlock(st.extrinsics[s].q)) {
      problem.SetManifold(st.extrinsics[s].q, graph.quaternion_manifold.get());
      if (options.mode == TrackingMode::kFixedExtrinsics) {
        problem.SetParameterBlockConstant(st.extrinsics[s].q);
        problem.SetParameterBlockConstant(st.extrinsics[s].t);
      }
    }
  }
  if (problem.HasParameterBlock(st.identity.q)) {
    problem.SetParameterBlockConstant(st.identity.q);
    problem.SetParameterBlockConstant(st.identity.t);
  }
  if (problem.HasParameterBlock(st.axis.q)) problem.SetManifold(st.axis.q, graph.quaternion_manifold.get());
  if (problem.HasParameterBlock(st.rig.q)) {
    problem.SetManifold(st.rig.q, graph.quaternion_manifold.get());
    // Gauge of T_r: a rotation of T_r about the axis is a shift of every azimuth; the gauge frame's
    // azimuth is held instead.
    problem.SetParameterBlockConstant(&st.alpha[st.ref][std::size_t(gauge)]);
  }
  // A frame of an active camera outside every factor (ba-only without observations) keeps its start.
  if (options.schur_ordering == "landmarks") graph.schur_ordering = landmarks_first_ordering(st, problem);
}

ceres::Solver::Summary solve_tracking_graph(FactorGraph& graph, const TrackingOptions& options,
                                            const std::string& origin, int* threads_used) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = options.linear_solver == "sparse_schur"      ? ceres::SPARSE_SCHUR
                                      : options.linear_solver == "dense_schur"     ? ceres::DENSE_SCHUR
                                      : options.linear_solver == "iterative_schur" ? ceres::ITERATIVE_SCHUR
                                                                                   : ceres::SPARSE_NORMAL_CHOLESKY;
  // Conjugate gradients on the reduced camera system, preconditioned by its diagonal blocks (no
  // Schur complement formed: the cost of a step grows with the observations, not their square).
  solver_options.preconditioner_type = ceres::SCHUR_JACOBI;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  // track.solver_threads (tracking.h): one by default, which makes the solve bit-identical for any
  // `threads`; 0 follows `threads`.
  const int threads = options.threads > 0 ? options.threads : int(std::max(1u, std::thread::hardware_concurrency()));
  solver_options.num_threads = options.solver_threads > 0 ? options.solver_threads : threads;
  solver_options.function_tolerance = options.function_tolerance;
  // track.initial_trust_region_radius (tracking.h): automatic = nearly Gauss-Newton from the start when
  // Eq. 2 ties the frames to the rotation model, Ceres' default for bundle adjustment alone.
  const bool regularised = !graph.blocks[kRegularisation].empty();
  solver_options.initial_trust_region_radius = options.initial_trust_region_radius > 0
                                                   ? options.initial_trust_region_radius
                                               : regularised ? 1e8
                                                             : 1e4;
  solver_options.logging_type = ceres::SILENT;
  const bool schur = solver_options.linear_solver_type != ceres::SPARSE_NORMAL_CHOLESKY;
  if (schur && graph.schur_ordering) solver_options.linear_solver_ordering = graph.schur_ordering;
  // The elimination order: landmarks first (fix_gauge, landmarks_first_ordering) unless
  // track.schur_ordering=automatic (recon/tracking/README.md, "Solver speed").
  IterationLogger iteration_logger(origin);
  if (options.log_iterations) solver_options.callbacks.push_back(&iteration_logger);
  ceres::Solver::Summary summary;
  if (threads_used) *threads_used = solver_options.num_threads;
  if (graph.problem->NumResidualBlocks() == 0) return summary;
  ceres::Solve(solver_options, graph.problem.get(), &summary);
  if (options.log_iterations) log_info(summary.FullReport());
  return summary;
}

TrackingResult extract_tracking_result(const TrackingState& st, const ScanIndex& scan, const TrackingOptions& options,
                                       bool* all_finite_out) {
  const int ref = st.ref;
  // The output's world is the first reference frame (tracking.h); the solve held gauge_frame's.
  const bool regauge = gauge_frame(st) != 0;
  const Rigid3d output_from_world = regauge ? st.poses[ref][0].pose().inverse() : Rigid3d::Identity();
  const auto in_output = [&](const PoseBlock& world_from_x) {
    return regauge ? Rigid3d(output_from_world * world_from_x.pose()) : world_from_x.pose();
  };
  TrackingResult result;
  result.depth_yaw_std_deg = st.depth_yaw_std_deg;
  RigTrajectory& trajectory = result.trajectory;
  trajectory.source = std::string("tracked:") + to_string(options.mode);
  trajectory.world_from_cam.resize(st.sensor_count);
  trajectory.ref_from_cam.resize(st.sensor_count);
  for (int s = 0; s < st.sensor_count; ++s) {
    const bool estimated = s != ref && st.active[s] && st.use_regularisation;
    trajectory.ref_from_cam[s] =
        estimated ? st.extrinsics[s].pose() : (s == ref ? Rigid3d::Identity() : scan.rig.sensors[s].ref_from_cam);
  }
  std::vector<Rigid3d> ref_poses;
  for (const PoseBlock& p : st.poses[ref]) ref_poses.push_back(in_output(p));
  Rigid3d world_from_axis;
  if (st.use_regularisation) {
    world_from_axis = in_output(st.axis);
  } else {
    const tracking_init::AxisEstimate fitted = tracking_init::fit_axis(ref_poses);
    world_from_axis = axis_frame(fitted.point, fitted.direction, ref_poses[0]);
  }
  trajectory.world_from_axis = axis_frame(world_from_axis.translation(), world_from_axis.linear().col(2), ref_poses[0]);
  const std::vector<double> ref_alpha = azimuths(ref_poses, trajectory.world_from_axis, Rigid3d::Identity());
  bool all_finite = finite(trajectory.world_from_axis);
  result.azimuth_rad.resize(st.sensor_count);
  result.azimuth_unwrapped_rad.resize(st.sensor_count);
  for (int s = 0; s < st.sensor_count; ++s) {
    std::vector<Rigid3d> world_from_cam;
    for (std::size_t f = 0; f < scan.frames[s].size(); ++f) {
      Rigid3d pose;
      if (st.active[s]) {
        pose = in_output(st.poses[s][f]);
      } else if (st.use_regularisation) {  // single-camera mode: the other cameras follow the Eq. 2 model
        const double a = interpolate(st.ref_times, st.alpha[ref], scan.frames[s][f].timestamp);
        pose = in_output(st.axis) * axis_rotation(a) * st.axis.pose().inverse() * st.rig.pose() *
               trajectory.ref_from_cam[s];
      } else if (st.handheld) {  // ... handheld: the reference camera's pose at that time, through T_c
        pose = reference_pose_at(st.ref_times, ref_poses, scan.frames[s][f].timestamp) * trajectory.ref_from_cam[s];
      } else {  // ... or, without Eq. 2, the rotation about the fitted axis
        const double a = interpolate(st.ref_times, ref_alpha, scan.frames[s][f].timestamp);
        pose = trajectory.world_from_axis * axis_rotation(a) * trajectory.world_from_axis.inverse() *
               trajectory.ref_from_cam[s];
      }
      all_finite = all_finite && finite(pose);
      trajectory.world_from_cam[s].push_back({scan.frames[s][f].timestamp, pose});
      world_from_cam.push_back(pose);
    }
    result.azimuth_unwrapped_rad[s] = azimuths(world_from_cam, trajectory.world_from_axis, trajectory.ref_from_cam[s]);
    for (double a : result.azimuth_unwrapped_rad[s]) result.azimuth_rad[s].push_back(wrap_two_pi(a));
  }
  if (all_finite_out) *all_finite_out = all_finite;
  return result;
}

namespace {

// The residuals of every block of one kind at the current state, without the loss function, in the
// order the blocks were added.
std::vector<double> unrobust_residuals(FactorGraph& graph, FactorKind kind) {
  std::vector<double> residuals;
  if (graph.blocks[kind].empty()) return residuals;
  ceres::Problem::EvaluateOptions evaluate;
  evaluate.residual_blocks = graph.blocks[kind];
  evaluate.apply_loss_function = false;
  evaluate.num_threads = 1;
  graph.problem->Evaluate(evaluate, nullptr, &residuals, nullptr, nullptr);
  return residuals;
}

}  // namespace

std::vector<double> observation_residual_norms(FactorGraph& graph) {
  const std::vector<double> residuals = unrobust_residuals(graph, kObservation);
  std::vector<double> norms;
  for (std::size_t k = 0; k + 2 < residuals.size(); k += 3)
    norms.push_back(std::sqrt(residuals[k] * residuals[k] + residuals[k + 1] * residuals[k + 1] +
                              residuals[k + 2] * residuals[k + 2]));
  return norms;
}

std::vector<std::vector<double>> depth_pair_residual_norms(FactorGraph& graph, const TrackingState& state) {
  std::vector<std::vector<double>> norms(std::size_t(state.sensor_count));
  for (int s = 0; s < state.sensor_count; ++s)
    norms[std::size_t(s)].assign(state.poses[s].size(), std::numeric_limits<double>::infinity());
  const std::vector<double> residuals = unrobust_residuals(graph, kDepthOdometry);
  for (std::size_t k = 0; k < graph.depth_pair_frames.size() && 6 * k + 5 < residuals.size(); ++k) {
    const auto [s, f] = graph.depth_pair_frames[k];
    norms[std::size_t(s)][std::size_t(f)] = Eigen::Map<const Eigen::Matrix<double, 6, 1>>(&residuals[6 * k]).norm();
  }
  return norms;
}

ModelDeparture model_departures(FactorGraph& graph, const TrackingState& state, const TrackingOptions& options) {
  ModelDeparture out;
  const std::vector<double> residuals = unrobust_residuals(graph, kRegularisation);
  if (residuals.empty()) return out;
  out.translation_mm.resize(std::size_t(state.sensor_count));
  out.rotation_deg.resize(std::size_t(state.sensor_count));
  // The blocks were added camera by camera, frame by frame (add_regularisation_factors); the
  // residual is (translation / sigma_t, rotation vector / sigma_r).
  std::size_t k = 0;
  const double sigma_t = options.reg_translation_std_m, sigma_r = deg2rad(options.reg_rotation_std_deg);
  for (int s = 0; s < state.sensor_count; ++s) {
    if (!state.active[s]) continue;
    for (std::size_t f = 0; f < state.poses[s].size() && 6 * k + 5 < residuals.size(); ++f, ++k) {
      const Eigen::Map<const Eigen::Matrix<double, 6, 1>> r(&residuals[6 * k]);
      out.translation_mm[std::size_t(s)].push_back(1e3 * (r.head<3>().norm() * sigma_t));
      out.rotation_deg[std::size_t(s)].push_back(rad2deg(r.tail<3>().norm() * sigma_r));
    }
  }
  return out;
}

}  // namespace panoscan::tracking_graph
