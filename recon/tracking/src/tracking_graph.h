// Internal to panoscan_recon_tracking (and its tests): the joint tracking of tracking.h as named
// steps, in the order track_with_frontend runs them:
//   initialise_tracking_state   odometry, axis and azimuths of the first guess (tracking.h)
//   add_observation_factors     Eq. 1
//   add_regularisation_factors  Eq. 2 and the priors on T_u and T_c
//   add_shared_wobble_factors   beyond the paper (tracking.h)
//   add_velocity_factors        Eq. 3
//   add_depth_odometry_factors  beyond the paper, optional (tracking.h)
//   fix_gauge                   manifolds, the gauge and the constant blocks
//   solve_tracking_graph        Eq. 4 (Levenberg-Marquardt)
//   extract_tracking_result     poses, axis, extrinsics and azimuths of the solution
// The verification of the result is verify_tracking (tracking.h).
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "panoscan/recon/tracking.h"

namespace panoscan::tracking_graph {

// A pose in Ceres' layout: unit quaternion (w, x, y, z) and translation.
struct PoseBlock {
  double q[4] = {1, 0, 0, 0};
  double t[3] = {0, 0, 0};

  static PoseBlock from(const Rigid3d& pose);
  Rigid3d pose() const;
};

// Every frame of the active cameras in timestamp order (ties by camera).
struct FrameNode {
  double t = 0.0;
  int s = 0, f = 0;
};

// The variables of the graph and what they are built from.
struct TrackingState {
  int sensor_count = 0, ref = 0;
  std::string origin;        // the scan, for messages
  std::vector<char> active;  // per sensor: in the graph
  bool use_regularisation = false, use_velocity = false;
  bool handheld = false;  // rig.json "motion": handheld (no Eq. 2-3; other cameras start from the reference's pose)
  std::vector<std::vector<PoseBlock>> poses;        // T_ci (world_from_cam) per sensor, per frame
  std::vector<std::vector<double>> alpha;           // alpha_ci, unwrapped
  std::vector<PoseBlock> extrinsics;                // T_c (ref_from_cam)
  PoseBlock axis;                                   // T_u (world_from_axis)
  PoseBlock rig;                                    // T_r (world_from_rig)
  PoseBlock identity;                               // the reference camera's T_c, held constant
  std::vector<double> ref_times;                    // timestamps of the reference frames
  std::vector<std::vector<Observation>> tracks;     // landmarks restricted to the active sensors
  std::vector<std::array<double, 3>> landmarks;     // y_j
  std::vector<std::vector<int>> observation_count;  // per sensor, per frame
  // Per sensor: T_c observed by landmarks it shares with the reference camera, directly or through
  // cameras that are (>= extrinsics_release_min_landmarks): its null-space prior is released.
  std::vector<char> extrinsics_observed;
  std::vector<FrameNode> nodes;                     // frames of the active cameras in time order
  // Per sensor, per frame f: the turn std of the depth-odometry pair (f, f + 1) (TrackingResult's field).
  std::vector<std::vector<double>> depth_yaw_std_deg;
};

// The Ceres problem with the blocks of each kind of factor (for the cost of each term).
enum FactorKind { kObservation, kRegularisation, kVelocity, kPriors, kSharedWobble, kDepthOdometry, kFactorKinds };

struct FactorGraph {
  FactorGraph();
  std::unique_ptr<ceres::Problem> problem;
  std::unique_ptr<ceres::QuaternionManifold> quaternion_manifold;
  std::unique_ptr<ceres::HuberLoss> huber;
  std::array<std::vector<ceres::ResidualBlockId>, kFactorKinds> blocks;
  int shared_wobble_links = 0;
  int depth_pairs = 0, depth_pairs_rejected = 0;  // add_depth_odometry_factors
  int depth_icp_iterations = 0;                   // summed over the aligned pairs
  // Per block of blocks[kDepthOdometry]: its camera and first frame (the pair is (f, f + 1)).
  std::vector<std::array<int, 2>> depth_pair_frames;
  std::unique_ptr<ceres::HuberLoss> depth_huber;
  // The Schur solvers' elimination order (fix_gauge, track.schur_ordering=landmarks); null = Ceres' own.
  std::shared_ptr<ceres::ParameterBlockOrdering> schur_ordering;

  // Ceres' 1/2 sum of squares of each kind of factor (Huber applied).
  std::array<double, kFactorKinds> term_costs() const;
};

// The first guess (tracking.h: chained odometry, fitted axis, interpolated azimuths), or
// `initial_guess` moved into the gauge when given. Throws Error when the reference camera has no
// frames or no verified frame pair.
TrackingState initialise_tracking_state(const ScanIndex& scan, const FrontendResult& frontend,
                                        const TrackingOptions& options, const RigTrajectory* initial_guess);

void add_observation_factors(FactorGraph& graph, TrackingState& state, const ScanIndex& scan,
                             const FrontendResult& frontend, const TrackingOptions& options);
void add_regularisation_factors(FactorGraph& graph, TrackingState& state, const TrackingOptions& options);
void add_shared_wobble_factors(FactorGraph& graph, TrackingState& state, const TrackingOptions& options);
void add_velocity_factors(FactorGraph& graph, TrackingState& state, const TrackingOptions& options);
// Beyond the paper (track.depth_odometry; depth_odometry.h): the ICP between consecutive frames of
// each active camera, started from the state's poses, as relative-pose factors. Uses the front
// end's depth grids, or reads the depth images when the front end kept none.
void add_depth_odometry_factors(FactorGraph& graph, TrackingState& state, const ScanIndex& scan,
                                const FrontendResult& frontend, const TrackingOptions& options);
// The reference frame the solve holds as the gauge: the first one (the output's world) unless Eq. 2
// ties frames to the rotator and that frame has no observations. A turn that starts facing a plain
// wall leaves its first frames to Eq. 2-3 and the depth odometry; holding the first of them makes the
// whole observed turn, with its landmarks, move along directions only those weak factors see, where
// the solver stops short (the test with ~40 deg of black frames at the start, the paper's graph:
// turn 355.6 -> 362.1 deg, worst position in those frames 23.8 -> 20.3 mm). The first reference
// frame with observations is held instead, and extract_tracking_result moves the world back to the
// first reference frame.
int gauge_frame(const TrackingState& state);
void fix_gauge(FactorGraph& graph, TrackingState& state, const TrackingOptions& options);

ceres::Solver::Summary solve_tracking_graph(FactorGraph& graph, const TrackingOptions& options,
                                            const std::string& origin, int* threads_used);

// The trajectory of every frame of the scan (inactive cameras follow the Eq. 2 model) and the
// azimuths; sets *all_finite.
TrackingResult extract_tracking_result(const TrackingState& state, const ScanIndex& scan,
                                       const TrackingOptions& options, bool* all_finite);

// Unwrapped azimuths of poses about the axis of world_from_axis (for a camera with extrinsics
// ref_from_cam): the twist of T_u^-1 T_ci T_c^-1 T_u about z.
std::vector<double> azimuths(const std::vector<Rigid3d>& world_from_cam, const Rigid3d& world_from_axis,
                             const Rigid3d& ref_from_cam);

// The whitened residual norm of every observation (Eq. 1) at the current state, per track, per
// observation, in the order of state.tracks (for the verification's residual statistics).
std::vector<double> observation_residual_norms(FactorGraph& graph);

// Per sensor, per frame f: the whitened norm of the depth-odometry factor of the pair (f, f + 1) at
// the current state, without its Huber loss (+inf where the graph has no such factor).
std::vector<std::vector<double>> depth_pair_residual_norms(FactorGraph& graph, const TrackingState& state);

// Per sensor, per frame: how far the frame's pose departs from the rotator model (Eq. 2's error
// transform at the current state, TrackingResult's units: translation in mm, rotation in deg); empty
// without Eq. 2.
struct ModelDeparture {
  std::vector<std::vector<double>> translation_mm, rotation_deg;
};
ModelDeparture model_departures(FactorGraph& graph, const TrackingState& state, const TrackingOptions& options);

}  // namespace panoscan::tracking_graph
