// Joint tracking of the unsynchronized cameras (paper §4.1) on a small simulated scan with noise:
// the full factor graph against its ablations, the axis and the extrinsics against the truth, and
// bad input. One scan and one front end are shared by the tests of the suite.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/SVD>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <tuple>

#include "panoscan/core/config.h"
#include "panoscan/core/error.h"
#include "panoscan/core/image_io.h"
#include "panoscan/core/scan.h"
#include "panoscan/eval/groundtruth.h"
#include "panoscan/eval/pose_error.h"
#include "panoscan/eval/trajectory_metrics.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"
#include "tracking_graph.h"

namespace panoscan {
namespace {

// The scans are at the default ICL-NUIM texture density (plain painted walls and ceilings): some
// frames of the tilted cameras see no features, which is what Eq. 2-3 are for.
const scenes::SceneStyle kIclStyle{scenes::TextureDensity::kIcl};

constexpr int kThreads = 2;

SimOptions small_scan_options() {
  SimOptions options;
  options.rig.width = 320;
  options.rig.height = 240;
  options.output.every = 16;  // 6 deg per frame of one camera at cruise speed (the paper's n = 16)
  options.noise.preset = NoisePreset::kHanda;
  options.seed = 7;
  options.threads = kThreads;
  return options;
}

// The paper's graph (Eq. 1-3 with the shared wobble): the tests below measure its factors and their
// ablations, which the depth odometry (on by default, beyond the paper) would mask; the depth
// odometry has a test of its own.
TrackingOptions test_tracking_options() {
  TrackingOptions options;
  options.depth_odometry = false;
  options.threads = kThreads;
  options.frontend.threads = kThreads;
  return options;
}

struct Figures {
  double ate_m = 0;  // mean over cameras of the per-camera ATE RMSE
  eval::AxisError axis;
  std::vector<eval::PoseError> extrinsics;
};

class TrackingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = std::make_unique<testutil::TempDir>("tracking");
    const Scene scene = scenes::make_builtin_scene("office", kIclStyle);
    const Simulator simulator(scene, 0, small_scan_options());
    simulator.write_scan(dir_->path() / "scan", false);
    scan_ = std::make_unique<ScanIndex>(read_scan_index(dir_->path() / "scan"));
    truth_ = std::make_unique<RigTrajectory>(eval::groundtruth_rig_trajectory(dir_->path() / "scan"));
    FrontendOptions frontend = test_tracking_options().frontend;
    frontend_ = std::make_unique<FrontendResult>(run_frontend(*scan_, frontend));
    std::printf("front end: %zu landmarks, pairs same %d cross %d loop %d, %.2f + %.2f ms/frame\n",
                frontend_->landmarks.size(), frontend_->same_camera_pairs, frontend_->cross_camera_pairs,
                frontend_->loop_pairs, frontend_->feature_ms_per_frame, frontend_->matching_ms_per_frame);
  }
  static void TearDownTestSuite() {
    frontend_.reset();
    truth_.reset();
    scan_.reset();
    dir_.reset();
  }

  static Figures evaluate(const TrackingResult& result, const std::string& label) {
    Figures figures;
    eval::TrajectoryMetricsOptions metrics_options;
    metrics_options.rpe_delta_s = 1.0;
    const int sensors = int(scan_->rig.sensors.size());
    for (int s = 0; s < sensors; ++s) {
      const auto metrics = eval::evaluate_trajectory(truth_->world_from_cam[s], result.trajectory.world_from_cam[s],
                                                     metrics_options, "truth", label);
      figures.ate_m += metrics.ate_m.rmse / sensors;
    }
    // The estimate lives in the frame of the reference camera's first frame. The ATE alignment
    // (positions only) is ill-conditioned in tilt, since the camera centres lie on a circle of
    // about 10 cm; the pose alignment uses the orientations of every frame as well.
    figures.axis =
        eval::axis_error(eval::axis_line(pose_alignment(result.trajectory) * result.trajectory.world_from_axis),
                         eval::axis_line(truth_->world_from_axis));
    figures.extrinsics = eval::extrinsics_errors(result.trajectory.ref_from_cam, truth_->ref_from_cam);
    std::printf(
        "%-22s ATE %.2f mm, axis %.3f deg %.2f mm, extrinsics cam0 %.3f deg %.2f mm cam2 %.3f deg %.2f mm, "
        "%d iterations, cost %.4g -> %.4g, solve %.2f s, %s\n",
        label.c_str(), 1e3 * figures.ate_m, figures.axis.angle_deg, 1e3 * figures.axis.offset_at_reference_m,
        figures.extrinsics[0].rotation_deg, 1e3 * figures.extrinsics[0].translation_m,
        figures.extrinsics[2].rotation_deg, 1e3 * figures.extrinsics[2].translation_m, result.stats.iterations,
        result.stats.initial_cost, result.stats.final_cost, result.stats.solve_seconds,
        result.stats.converged ? "converged" : result.stats.termination.c_str());
    return figures;
  }

  // truth_from_estimate over all frames of all cameras: the rotation is the chordal mean of
  // R_true R_est^T (its projection onto SO(3)), the translation matches the centroids.
  static Rigid3d pose_alignment(const RigTrajectory& estimate) {
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    Eigen::Vector3d truth_centroid = Eigen::Vector3d::Zero(), estimate_centroid = Eigen::Vector3d::Zero();
    int count = 0;
    for (std::size_t s = 0; s < estimate.world_from_cam.size(); ++s)
      for (std::size_t f = 0; f < estimate.world_from_cam[s].size(); ++f) {
        const Rigid3d& t = truth_->world_from_cam[s][f].world_from_cam;
        const Rigid3d& e = estimate.world_from_cam[s][f].world_from_cam;
        sum += t.linear() * e.linear().transpose();
        truth_centroid += t.translation();
        estimate_centroid += e.translation();
        ++count;
      }
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU();
    if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) *= -1;
    const Eigen::Matrix3d rotation = u * svd.matrixV().transpose();
    return make_rigid(rotation, (truth_centroid - rotation * estimate_centroid) / count);
  }

  // Runs (once per label: the tests share results) and evaluates one configuration.
  static Figures run(const TrackingOptions& options, const std::string& label, TrackingResult* out = nullptr) {
    static std::map<std::string, std::pair<Figures, TrackingResult>> cache;
    if (auto it = cache.find(label); it != cache.end()) {
      if (out) *out = it->second.second;
      return it->second.first;
    }
    TrackingResult result = track_with_frontend(*scan_, *frontend_, options);
    check_rig_trajectory(result.trajectory, *scan_, label);
    const Figures figures = evaluate(result, label);
    cache[label] = {figures, result};
    if (out) *out = std::move(result);
    return figures;
  }

  // The calibrated extrinsics' errors against the truth: where the tracking starts from.
  static std::vector<eval::PoseError> calibrated_extrinsics_errors() {
    std::vector<Rigid3d> ref_from_cam;
    for (const auto& sensor : scan_->rig.sensors) ref_from_cam.push_back(sensor.ref_from_cam);
    return eval::extrinsics_errors(ref_from_cam, truth_->ref_from_cam);
  }

  static std::unique_ptr<testutil::TempDir> dir_;
  static std::unique_ptr<ScanIndex> scan_;
  static std::unique_ptr<RigTrajectory> truth_;
  static std::unique_ptr<FrontendResult> frontend_;
};

std::unique_ptr<testutil::TempDir> TrackingTest::dir_;
std::unique_ptr<ScanIndex> TrackingTest::scan_;
std::unique_ptr<RigTrajectory> TrackingTest::truth_;
std::unique_ptr<FrontendResult> TrackingTest::frontend_;

TEST_F(TrackingTest, FrontEndFindsTracksAcrossCamerasAndTheLoop) {
  EXPECT_GT(frontend_->landmarks.size(), 500u);
  // Cross-camera pairs (recon/tracking/README.md, "Cross-camera matching"): at the default rig's
  // overlap (a few pixels at 320x240) few or none are found here; TrackingBand below asserts them.
  // ORB's funnel: one candidate per frame of the upper camera of each overlapping pair (the top and
  // bottom cameras never overlap), each step a subset of the one before.
  const CrossCameraFunnel& funnel = frontend_->cross_camera;
  const int expected_candidates = int(scan_->frames[0].size() + scan_->frames[1].size());
  EXPECT_EQ(funnel.candidates, expected_candidates);
  EXPECT_GE(funnel.candidates, funnel.with_band_keypoints);
  EXPECT_GE(funnel.with_band_keypoints, funnel.with_matches);
  EXPECT_GE(funnel.with_matches, funnel.with_ransac);
  EXPECT_GE(funnel.with_ransac, funnel.accepted);
  // Band alignment's: band_frames frames of the other camera per frame, the same chain of subsets.
  EXPECT_EQ(funnel.band_candidates, FrontendOptions{}.band_frames * expected_candidates);
  EXPECT_GE(funnel.band_candidates, funnel.band_with_anchors);
  EXPECT_GE(funnel.band_anchors, funnel.band_aligned);
  EXPECT_GE(funnel.band_aligned, funnel.band_matches);
  EXPECT_EQ(funnel.accepted + funnel.band_accepted, frontend_->cross_camera_pairs);
  ASSERT_EQ(funnel.band_relations.size(), 2u);
  EXPECT_GT(frontend_->loop_pairs, 0);
  // The plain walls and ceiling leave some frames of the tilted cameras without features (measured
  // 20 of 186), the case Eq. 2-3 are for; most frames have them.
  int frames = 0;
  for (const auto& camera : scan_->frames) frames += int(camera.size());
  EXPECT_GT(frontend_->frames_without_features, 0);
  EXPECT_LT(frontend_->frames_without_features, frames / 4);
}

TEST_F(TrackingTest, FullGraphBeatsItsAblationsAndRecoversAxisAndExtrinsics) {
  TrackingResult full_result;
  const Figures full = run(test_tracking_options(), "full", &full_result);
  EXPECT_TRUE(full_result.stats.converged) << full_result.stats.termination;

  TrackingOptions ba = test_tracking_options();
  ba.mode = TrackingMode::kBaOnly;
  const Figures ba_only = run(ba, "ba-only");

  TrackingOptions no_velocity = test_tracking_options();
  no_velocity.velocity_smoothness = false;
  const Figures without_eq3 = run(no_velocity, "without Eq. 3");

  TrackingOptions no_regularisation = test_tracking_options();
  no_regularisation.pose_regularisation = false;
  const Figures without_eq2 = run(no_regularisation, "without Eq. 2");

  TrackingOptions independent_wobble = test_tracking_options();
  independent_wobble.shared_wobble = false;
  const Figures without_shared_wobble = run(independent_wobble, "without shared wobble");

  // The full graph beats BA alone and each graph without one of its regularising factors
  // (measured ATE: full 4.26, BA only 37.6, without Eq. 2 37.6, without Eq. 3 6.09, without the
  // shared wobble 8.13 mm; before the bulk normal stream changed the noise's realisation: 4.52, 31.55,
  // 31.55, 6.41, 8.97 mm). On the rich texture density Eq. 3 made no difference (1.65 mm either
  // way): it carries the frames that see plain walls.
  EXPECT_LT(full.ate_m, 0.4 * ba_only.ate_m);
  EXPECT_LT(full.ate_m, 0.4 * without_eq2.ate_m);
  EXPECT_LT(full.ate_m, 0.7 * without_shared_wobble.ate_m);
  EXPECT_LT(full.ate_m, 0.85 * without_eq3.ate_m);
  EXPECT_LT(full.ate_m, 0.0065);
  // Axis within 0.25 deg and 5 mm of the truth (issue: 0.5 deg and 1 cm), pose-aligned. Measured
  // 0.13 deg, 1.25 mm (BA only: 1.21 deg, 5.6 mm). (The free rig pose T_r of tracking.h makes no
  // difference on this scan, whose first frame wobbles little; gate_table2 checks it on SO-1 and SL-1.)
  EXPECT_LT(full.axis.angle_deg, 0.25);
  EXPECT_LT(full.axis.offset_at_reference_m, 0.005);
  // Refined extrinsics: their rotations closer to the truth than the calibrated ones they started
  // from, summed over the non-reference cameras (one camera's may get worse: with no cross-camera
  // landmarks in the simulated rig's 0.6 deg overlap, Eq. 2 alone refines T_c; see the report).
  // Their translations are barely observed by this graph on this 320x240 scan (measured, summed:
  // 9.4 and 10.1 mm against 10 mm calibrated on two noise realisations, one camera better, one
  // worse): they must not run away; the depth odometry's test below asserts that they improve.
  const auto calibrated = calibrated_extrinsics_errors();
  double calibrated_deg = 0, calibrated_m = 0, tracked_deg = 0, tracked_m = 0;
  for (int s = 0; s < int(calibrated.size()); ++s) {
    if (s == scan_->rig.reference_sensor) continue;
    std::printf("cam%d extrinsics: calibrated %.3f deg %.2f mm -> tracked %.3f deg %.2f mm\n", s,
                calibrated[s].rotation_deg, 1e3 * calibrated[s].translation_m, full.extrinsics[s].rotation_deg,
                1e3 * full.extrinsics[s].translation_m);
    calibrated_deg += calibrated[s].rotation_deg;
    calibrated_m += calibrated[s].translation_m;
    tracked_deg += full.extrinsics[s].rotation_deg;
    tracked_m += full.extrinsics[s].translation_m;
  }
  EXPECT_LT(tracked_deg, calibrated_deg);
  EXPECT_LT(tracked_m, 1.3 * calibrated_m);
}

TEST_F(TrackingTest, DepthOdometryHoldsThePlainFramesBetterThanEq2And3Alone) {
  // Beyond the paper (track.depth_odometry): point-to-plane ICP between consecutive frames of each
  // camera as relative-pose factors. The suite's front end kept no depth grids, so the step reads
  // the depth images itself; a front end that kept them must give the same trajectory.
  const Figures full = run(test_tracking_options(), "full");
  TrackingOptions with_depth = test_tracking_options();
  with_depth.depth_odometry = true;
  TrackingResult depth_result;
  const Figures depth = run(with_depth, "with depth odometry", &depth_result);
  std::printf("depth odometry: %d pairs used, %d rejected, %.2f s\n", depth_result.stats.depth_pairs,
              depth_result.stats.depth_pairs_rejected, depth_result.stats.depth_odometry_seconds);
  EXPECT_TRUE(depth_result.verdict.reliable) << depth_result.verdict.first_failure();
  // Nearly every consecutive pair overlaps enough (3 cameras x (frames - 1) pairs).
  int pairs = 0;
  for (const auto& frames : scan_->frames) pairs += int(frames.size()) - 1;
  EXPECT_GE(depth_result.stats.depth_pairs, int(0.9 * pairs));
  // Measured ATE (320x240, seed 7): 4.26 mm without, 1.17 mm with the depth odometry.
  EXPECT_LT(depth.ate_m, 0.6 * full.ate_m);
  // With it the extrinsics' translations are observed: each camera's and their sum closer to the
  // truth than the calibration (measured, summed: 2.8 mm against 10 mm calibrated).
  const auto calibrated = calibrated_extrinsics_errors();
  double calibrated_m = 0, tracked_m = 0;
  for (int s = 0; s < int(calibrated.size()); ++s) {
    if (s == scan_->rig.reference_sensor) continue;
    EXPECT_LT(depth.extrinsics[s].translation_m, calibrated[s].translation_m) << "cam" << s;
    calibrated_m += calibrated[s].translation_m;
    tracked_m += depth.extrinsics[s].translation_m;
  }
  EXPECT_LT(tracked_m, 0.6 * calibrated_m);
  // Bundle adjustment stays Eq. 1 alone: the option does not enter ba-only mode.
  TrackingOptions ba = with_depth;
  ba.mode = TrackingMode::kBaOnly;
  EXPECT_EQ(track_with_frontend(*scan_, *frontend_, ba).stats.depth_pairs, 0);

  FrontendOptions keeping_grids = test_tracking_options().frontend;
  keeping_grids.depth_grid_block = with_depth.depth_odometry_block_px;
  const FrontendResult with_grids = run_frontend(*scan_, keeping_grids);
  ASSERT_EQ(with_grids.depth_grids.size(), scan_->frames.size());
  with_depth.threads = 1;
  const TrackingResult from_grids = track_with_frontend(*scan_, with_grids, with_depth);
  const TrackingResult from_images = track_with_frontend(*scan_, *frontend_, with_depth);
  for (std::size_t s = 0; s < scan_->frames.size(); ++s)
    for (std::size_t f = 0; f < scan_->frames[s].size(); ++f)
      EXPECT_TRUE(from_grids.trajectory.world_from_cam[s][f].world_from_cam.isApprox(
          from_images.trajectory.world_from_cam[s][f].world_from_cam, 1e-12))
          << s << " " << f;
}

TEST_F(TrackingTest, SingleCameraIsWorseThanTheRig) {
  const Figures full = run(test_tracking_options(), "full");
  TrackingOptions single = test_tracking_options();
  single.mode = TrackingMode::kSingleCamera;
  const Figures one_camera = run(single, "single-camera");
  EXPECT_LT(full.ate_m, one_camera.ate_m);
}

TEST_F(TrackingTest, DeterministicAndWritesOutputs) {
  // The front end is identical for any thread count, and the solve runs on one Ceres thread
  // (track.solver_threads; Ceres' multi-threaded reductions reorder floating-point sums), so the
  // trajectory is bit for bit the same for one and for two threads, run after run.
  FrontendOptions frontend_options = test_tracking_options().frontend;
  frontend_options.threads = 1;
  const FrontendResult single_thread = run_frontend(*scan_, frontend_options);
  ASSERT_EQ(single_thread.landmarks.size(), frontend_->landmarks.size());
  for (std::size_t j = 0; j < single_thread.landmarks.size(); ++j)
    ASSERT_EQ(single_thread.landmarks[j].size(), frontend_->landmarks[j].size());
  TrackingOptions options = test_tracking_options();
  options.max_iterations = 5;
  options.threads = 1;
  const TrackingResult a = track_with_frontend(*scan_, *frontend_, options);
  options.threads = kThreads;
  const TrackingResult b = track_with_frontend(*scan_, *frontend_, options);
  const TrackingResult c = track_with_frontend(*scan_, *frontend_, options);
  EXPECT_EQ(b.stats.threads, 1);
  for (std::size_t s = 0; s < a.trajectory.world_from_cam.size(); ++s)
    for (std::size_t f = 0; f < a.trajectory.world_from_cam[s].size(); ++f) {
      ASSERT_EQ(a.trajectory.world_from_cam[s][f].world_from_cam.matrix(),
                b.trajectory.world_from_cam[s][f].world_from_cam.matrix());
      ASSERT_EQ(b.trajectory.world_from_cam[s][f].world_from_cam.matrix(),
                c.trajectory.world_from_cam[s][f].world_from_cam.matrix());
    }
  write_tracking_result(dir_->path() / "out", a, scan_->rig);
  const RigTrajectory reread = read_rig_trajectory(dir_->path() / "out", *scan_);
  EXPECT_TRUE(reread.world_from_axis.isApprox(a.trajectory.world_from_axis, 1e-6));
  EXPECT_TRUE(std::filesystem::exists(dir_->path() / "out" / "tracking_stats.json"));
}

// track.schur_ordering=landmarks: the Schur solvers eliminate exactly the landmarks (so that Ceres
// uses its <3,3,3> eliminator) and every other block keeps a group of its own in the graph's
// order; the solution is the one Ceres' automatic ordering reaches.
TEST_F(TrackingTest, TheLandmarksFirstOrderingEliminatesTheLandmarksAndReachesTheSameSolution) {
  namespace tg = tracking_graph;
  TrackingOptions options = test_tracking_options();
  options.threads = 1;
  // The graph up to the solve, as track_with_frontend builds it.
  auto build_graph = [&](tg::TrackingState& state, tg::FactorGraph& graph) {
    state = tg::initialise_tracking_state(*scan_, *frontend_, options, nullptr);
    tg::add_observation_factors(graph, state, *scan_, *frontend_, options);
    tg::add_regularisation_factors(graph, state, options);
    tg::add_shared_wobble_factors(graph, state, options);
    tg::add_velocity_factors(graph, state, options);
    tg::fix_gauge(graph, state, options);
  };
  tg::TrackingState state;
  tg::FactorGraph graph;
  build_graph(state, graph);
  ASSERT_TRUE(graph.schur_ordering);
  const ceres::ParameterBlockOrdering& ordering = *graph.schur_ordering;
  EXPECT_EQ(ordering.NumElements(), graph.problem->NumParameterBlocks());
  EXPECT_EQ(ordering.GroupSize(0), int(state.landmarks.size()));
  for (auto& landmark : state.landmarks) EXPECT_EQ(ordering.GroupId(landmark.data()), 0);
  EXPECT_EQ(ordering.NumGroups(), 1 + graph.problem->NumParameterBlocks() - int(state.landmarks.size()));
  // The other blocks follow a fill-reducing order computed from the graph alone: a second graph of
  // the same scan, its blocks elsewhere in memory, gets the same order (Ceres' own CAMD, given one
  // group, ordered by address and was not reproducible).
  {
    tg::TrackingState again;
    tg::FactorGraph other;
    build_graph(again, other);
    ASSERT_TRUE(other.schur_ordering);
    int compared = 0, time_ordered = 0;
    int previous_group = -1;
    for (const tg::FrameNode& node : state.nodes) {
      const int group = ordering.GroupId(state.poses[node.s][node.f].q);
      EXPECT_EQ(group, other.schur_ordering->GroupId(again.poses[node.s][node.f].q));
      EXPECT_EQ(ordering.GroupId(state.poses[node.s][node.f].t),
                other.schur_ordering->GroupId(again.poses[node.s][node.f].t));
      time_ordered += group > previous_group;
      previous_group = group;
      ++compared;
    }
    EXPECT_GT(compared, 100);
    // Not simply the frames in time order (what the ordering was before AMD).
    EXPECT_LT(time_ordered, compared);
  }

  TrackingOptions automatic = options;
  automatic.schur_ordering = "automatic";
  const TrackingResult ours = track_with_frontend(*scan_, *frontend_, options);
  const TrackingResult ceres_own = track_with_frontend(*scan_, *frontend_, automatic);
  EXPECT_EQ(ours.stats.iterations, ceres_own.stats.iterations);
  EXPECT_NEAR(ours.stats.final_cost, ceres_own.stats.final_cost, 1e-8 * ceres_own.stats.final_cost);
  double largest_m = 0;
  for (std::size_t s = 0; s < ours.trajectory.world_from_cam.size(); ++s)
    for (std::size_t f = 0; f < ours.trajectory.world_from_cam[s].size(); ++f)
      largest_m = std::max(largest_m, (ours.trajectory.world_from_cam[s][f].world_from_cam.translation() -
                                       ceres_own.trajectory.world_from_cam[s][f].world_from_cam.translation())
                                          .norm());
  EXPECT_LT(largest_m, 1e-6);
}

// frontend.orb_levels = 0 (the default): 3 pyramid levels on a rotator, 8 for a handheld recording
// (recon/tracking/README.md, "ORB pyramid levels"); a value set is used as it is.
TEST(FrontendOrbLevels, ByTheScansMotionUnlessSet) {
  FrontendOptions options;
  EXPECT_EQ(options.orb_levels, 0);
  EXPECT_EQ(orb_levels_for(options, RigMotion::kRotator), 3);
  EXPECT_EQ(orb_levels_for(options, RigMotion::kHandheld), 8);
  options.orb_levels = 5;
  EXPECT_EQ(orb_levels_for(options, RigMotion::kRotator), 5);
  EXPECT_EQ(orb_levels_for(options, RigMotion::kHandheld), 5);
  Config set =
      Config::from_string("frontend: {orb_levels: 4, orb_scale_factor: 1.3, orb_fast_threshold: 9}\n", "t.yaml");
  const TrackingOptions from_config = tracking_options_from_config(set);
  EXPECT_EQ(from_config.frontend.orb_levels, 4);
  EXPECT_DOUBLE_EQ(from_config.frontend.orb_scale_factor, 1.3);
  EXPECT_EQ(from_config.frontend.orb_fast_threshold, 9);
  Config out_of_range = Config::from_string("frontend: {orb_levels: 17}\n", "levels.yaml");
  try {
    tracking_options_from_config(out_of_range);
    ADD_FAILURE() << "orb_levels 17 accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frontend.orb_levels"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("levels.yaml"), std::string::npos) << e.what();
  }
}

// The levels reach ORB: the rotator's front end (the fixture's, by default) detects on 3 levels, a set
// value on that many; 3 levels put more keypoints on the finest one (OpenCV's per-level quota: 40% of
// them with 3 levels, 22% with 8). Fails if the levels do not reach ORB, or the default not the front end.
TEST_F(TrackingTest, TheRotatorsFrontEndDetectsOnThreePyramidLevels) {
  auto octaves = [](const FrontendResult& result) {
    int finest = 0, keypoints = 0, highest = -1;
    for (const auto& camera : result.features)
      for (const FrameFeatures& frame : camera)
        for (const Keypoint& k : frame.keypoints) {
          finest += k.octave == 0 ? 1 : 0;
          highest = std::max(highest, k.octave);
          ++keypoints;
        }
    return std::make_tuple(double(finest) / std::max(1, keypoints), highest, keypoints);
  };
  EXPECT_EQ(frontend_->orb_levels, kRotatorOrbLevels);
  const auto [finest3, highest3, keypoints3] = octaves(*frontend_);
  FrontendOptions eight = test_tracking_options().frontend;
  eight.orb_levels = 8;
  const FrontendResult result8 = run_frontend(*scan_, eight);
  EXPECT_EQ(result8.orb_levels, 8);
  const auto [finest8, highest8, keypoints8] = octaves(result8);
  std::printf("keypoints at octave 0: %.2f of %d (3 levels), %.2f of %d (8 levels)\n", finest3, keypoints3, finest8,
              keypoints8);
  EXPECT_EQ(highest3, 2);
  EXPECT_GE(highest8, 3);
  EXPECT_LE(highest8, 7);
  EXPECT_GT(finest3, finest8 + 0.1);
  const nlohmann::json stats = nlohmann::json::parse(
      tracking_stats_json(track_with_frontend(*scan_, *frontend_, test_tracking_options()), scan_->rig));
  EXPECT_EQ(stats.at("orb_levels").get<int>(), kRotatorOrbLevels);
}

// frontend.guided_matching: same-camera and loop pairs matched by projection compare each keypoint with
// the few near its predicted position instead of all of them; they must verify the pairs brute
// force verifies, with the same transforms, and track as well.
TEST_F(TrackingTest, MatchingByProjectionVerifiesThePairsBruteForceVerifies) {
  FrontendOptions brute_options = test_tracking_options().frontend;
  ASSERT_TRUE(brute_options.guided_matching);
  brute_options.guided_matching = false;
  const FrontendResult brute = run_frontend(*scan_, brute_options);
  EXPECT_EQ(brute.guided_pairs, 0);
  // Most same-camera pairs are guided (the rest: frames of plain wall with too few keypoints for a
  // sample, matched brute force).
  int same_camera_tasks = 0;  // and loop pairs
  for (const auto& camera : scan_->frames) {
    for (int f = 1; f < int(camera.size()); ++f) same_camera_tasks += std::min(f, brute_options.same_camera_window);
    if (int(camera.size()) > 4 * brute_options.loop_frames)
      same_camera_tasks += brute_options.loop_frames * brute_options.loop_frames;
  }
  // (Pairs with a frame of fewer than min_inliers keypoints are neither: they are not matched.)
  EXPECT_LE(frontend_->guided_pairs + frontend_->guided_fallbacks, same_camera_tasks);
  EXPECT_GT(frontend_->guided_pairs, (frontend_->guided_pairs + frontend_->guided_fallbacks) / 2);
  std::printf("same-camera and loop pairs: %d guided, %d brute force; accepted %d + %d (guided) vs %d + %d\n",
              frontend_->guided_pairs, frontend_->guided_fallbacks, frontend_->same_camera_pairs, frontend_->loop_pairs,
              brute.same_camera_pairs, brute.loop_pairs);
  EXPECT_GE(frontend_->same_camera_pairs, brute.same_camera_pairs - std::max(2, brute.same_camera_pairs / 50));
  EXPECT_GE(frontend_->loop_pairs, brute.loop_pairs * 9 / 10);
  EXPECT_GT(frontend_->loop_pairs, 0);
  // Against the true relative poses: guided matching keeps the pairs' accuracy (about as many wrong
  // pairs, the same typical error).
  auto pair_errors = [&](const FrontendResult& result) {
    std::vector<double> errors_deg;
    int wrong = 0;
    for (const FramePairMatch& m : result.pairs) {
      if (m.kind != FramePairMatch::Kind::kSameCamera) continue;
      const Rigid3d truth = truth_->world_from_cam[m.sensor_a][m.frame_a].world_from_cam.inverse() *
                            truth_->world_from_cam[m.sensor_b][m.frame_b].world_from_cam;
      const Rigid3d difference = truth.inverse() * m.a_from_b;
      const double deg = rad2deg(rotation_angle(difference.linear())), mm = 1e3 * difference.translation().norm();
      errors_deg.push_back(deg);
      if (deg > 1.0 || mm > 30.0) ++wrong;
    }
    std::sort(errors_deg.begin(), errors_deg.end());
    return std::make_pair(wrong, errors_deg.empty() ? 0.0 : errors_deg[errors_deg.size() / 2]);
  };
  const auto [guided_wrong, guided_median_deg] = pair_errors(*frontend_);
  const auto [brute_wrong, brute_median_deg] = pair_errors(brute);
  std::printf("pairs off the truth by > 1 deg or 30 mm: %d guided, %d brute force; median %.3f vs %.3f deg\n",
              guided_wrong, brute_wrong, guided_median_deg, brute_median_deg);
  // Within 2% of the pairs, as the pair counts above: the two searches keep different keypoints, and
  // the count of pairs near the 1 deg / 30 mm line moves by a few either way (55 vs 57 with ORB's 8
  // levels, 56 vs 52 with 3).
  EXPECT_LE(guided_wrong, brute_wrong + std::max(2, brute.same_camera_pairs / 50));
  EXPECT_LT(guided_median_deg, 1.2 * brute_median_deg + 0.01);
  // And the tracking is as good (the fixture's front end is the guided one).
  const Figures guided = run(test_tracking_options(), "full");
  TrackingResult brute_result = track_with_frontend(*scan_, brute, test_tracking_options());
  const Figures brute_figures = evaluate(brute_result, "brute-force matching");
  EXPECT_LT(guided.ate_m, 1.25 * brute_figures.ate_m + 0.5e-3);
}

TEST_F(TrackingTest, FramesWithoutFeaturesAreKeptWithTheRegularisingFactors) {
  // A copy of the scan where every camera sees black for a run of frames (a lens cap, a black
  // wall): those frames keep only Eq. 2 and 3, which carry the rotation through the gap.
  const auto copy = dir_->path() / "black";
  std::filesystem::copy(scan_->root, copy, std::filesystem::copy_options::recursive);
  const ScanIndex scan = read_scan_index(copy);
  constexpr int kFirst = 20, kLast = 24;
  for (int s = 0; s < int(scan.frames.size()); ++s)
    for (int f = kFirst; f <= kLast; ++f) {
      const auto path = copy / scan.rig.sensors[s].name / scan.frames[s][f].rgb_file;
      ImageU8 black = read_rgb(path);
      std::fill(black.data.begin(), black.data.end(), 0);
      write_png(path, black);
    }
  const FrontendResult frontend = run_frontend(scan, test_tracking_options().frontend);
  auto gap_error = [&](const TrackingResult& result, const std::string& label) {
    check_rig_trajectory(result.trajectory, scan, label);
    eval::TrajectoryMetricsOptions metrics_options;
    double worst = 0;
    for (int s = 0; s < int(scan.frames.size()); ++s) {
      const auto metrics = eval::evaluate_trajectory(truth_->world_from_cam[s], result.trajectory.world_from_cam[s],
                                                     metrics_options, "truth", label);
      for (std::size_t k = 0; k < metrics.timestamps.size(); ++k)
        if (metrics.timestamps[k] >= scan.frames[s][kFirst].timestamp &&
            metrics.timestamps[k] <= scan.frames[s][kLast].timestamp)
          worst = std::max(worst, (metrics.gt_positions[k] - metrics.est_positions_aligned[k]).norm());
    }
    std::printf("%s: worst position error in the black frames %.2f mm, %s\n", label.c_str(), 1e3 * worst,
                result.stats.converged ? "converged" : result.stats.termination.c_str());
    return worst;
  };
  const TrackingResult with_eq3 = track_with_frontend(scan, frontend, test_tracking_options());
  EXPECT_GE(with_eq3.stats.frames_without_features, 3 * (kLast - kFirst + 1));
  EXPECT_GE(with_eq3.stats.frames_without_observations, 3 * (kLast - kFirst + 1));
  TrackingOptions no_velocity = test_tracking_options();
  no_velocity.velocity_smoothness = false;
  const TrackingResult without_eq3 = track_with_frontend(scan, frontend, no_velocity);
  const double error_with = gap_error(with_eq3, "black, full");
  const double error_without = gap_error(without_eq3, "black, without Eq. 3");
  EXPECT_LT(error_with, 0.025);
  // Measured 16.5 vs 19.4 mm. Fully converged (function tolerance 1e-9) the full graph gives 16.6 mm and the
  // graph without Eq. 3 18.6-19.2 mm (it does not converge in 100 iterations along its weak direction): Eq. 3
  // is worth 11-14% here. (The earlier 15.7 vs 21.2 mm were both stopped short of their optima by the first
  // radius of 1e4; rich density: 9.6 vs 14.6.) Without Eq. 3 in both runs the ratio is 1.
  EXPECT_LT(error_with, 0.9 * error_without);
}

TEST_F(TrackingTest, ATurnThatStartsFacingNothingIsPlacedFromTheFramesAfter) {
  // Every camera sees black for the first frames (the turn starts facing a plain wall): nothing
  // observes them, and the first reference frame is the output's world. Chained from frame 0 as
  // though the rotator had stood still, the rest of the turn started where frame 0 was and the
  // solver left it there: a generated living room was tracked 23 deg short (tracking_graph.h,
  // gauge_frame; tracking_init.cpp, extrapolate_leading_gap).
  const auto copy = dir_->path() / "black_start";
  std::filesystem::copy(scan_->root, copy, std::filesystem::copy_options::recursive);
  const ScanIndex scan = read_scan_index(copy);
  constexpr int kLast = 6;  // frames 0-6 of each camera: about 40 deg of the turn
  for (int s = 0; s < int(scan.frames.size()); ++s)
    for (int f = 0; f <= kLast; ++f) {
      const auto path = copy / scan.rig.sensors[s].name / scan.frames[s][f].rgb_file;
      ImageU8 black = read_rgb(path);
      std::fill(black.data.begin(), black.data.end(), 0);
      write_png(path, black);
    }
  const FrontendResult frontend = run_frontend(scan, test_tracking_options().frontend);
  {
    // The solve holds the first reference frame that has observations, not frame 0, which nothing
    // observes; the output is moved back to frame 0 (checked below).
    namespace tg = tracking_graph;
    const TrackingOptions options = test_tracking_options();
    tg::TrackingState state = tg::initialise_tracking_state(scan, frontend, options, nullptr);
    tg::FactorGraph graph;
    tg::add_observation_factors(graph, state, scan, frontend, options);
    tg::add_regularisation_factors(graph, state, options);
    tg::add_velocity_factors(graph, state, options);
    tg::fix_gauge(graph, state, options);
    const int ref = scan.rig.reference_sensor, gauge = tg::gauge_frame(state);
    EXPECT_GT(gauge, kLast);
    EXPECT_EQ(state.observation_count[std::size_t(ref)][std::size_t(gauge - 1)], 0);
    EXPECT_GT(state.observation_count[std::size_t(ref)][std::size_t(gauge)], 0);
    EXPECT_TRUE(graph.problem->IsParameterBlockConstant(state.poses[std::size_t(ref)][std::size_t(gauge)].t));
    EXPECT_FALSE(graph.problem->IsParameterBlockConstant(state.poses[std::size_t(ref)][0].t));
  }
  for (const bool depth_odometry : {false, true}) {
    TrackingOptions options = test_tracking_options();
    options.depth_odometry = depth_odometry;
    const std::string label = depth_odometry ? "black start, + depth odometry" : "black start";
    const TrackingResult result = track_with_frontend(scan, frontend, options);
    check_rig_trajectory(result.trajectory, scan, label);
    const Rigid3d& first =
        result.trajectory.world_from_cam[std::size_t(scan.rig.reference_sensor)].front().world_from_cam;
    EXPECT_TRUE(first.isApprox(Rigid3d::Identity(), 1e-9))
        << label << ": the output's world is the first reference frame";
    double worst = 0, ate = 0;
    for (int s = 0; s < int(scan.frames.size()); ++s) {
      const auto metrics =
          eval::evaluate_trajectory(truth_->world_from_cam[s], result.trajectory.world_from_cam[s], {}, "truth", label);
      ate += metrics.ate_m.rmse / double(scan.frames.size());
      for (std::size_t k = 0; k < metrics.timestamps.size(); ++k)
        if (metrics.timestamps[k] <= scan.frames[s][kLast].timestamp)
          worst = std::max(worst, (metrics.gt_positions[k] - metrics.est_positions_aligned[k]).norm());
    }
    const TrackingVerdict& verdict = result.verdict;
    double turn = 0;
    for (const TrackingCheck& check : verdict.checks)
      if (check.name == "turn") turn = check.value;
    std::printf("%s: ATE %.2f mm, worst position error in the black frames %.2f mm, turn %.1f deg, %s\n", label.c_str(),
                1e3 * ate, 1e3 * worst, turn, verdict.reliable ? "reliable" : verdict.first_failure().c_str());
    // Measured: 20.3 mm in the black frames and 11.3 mm ATE with Eq. 2-3 alone, 5.2 and 1.5 mm with the
    // depth odometry; chained from a standing start, 45.6 mm and a turn 334 deg short of one revolution
    // (refused), and 54.5 and 8.9 mm with the depth odometry.
    EXPECT_TRUE(verdict.checked && verdict.reliable) << label << ": " << verdict.first_failure();
    EXPECT_LT(worst, depth_odometry ? 0.015 : 0.030) << label;
    EXPECT_LT(ate, depth_odometry ? 0.005 : 0.015) << label;
  }
}

TEST_F(TrackingTest, SelfCheckPassesACorrectTrajectoryAndCatchesCorruptedOnes) {
  const TrackingResult good = track_with_frontend(*scan_, *frontend_, test_tracking_options());
  ASSERT_TRUE(good.verdict.checked);
  EXPECT_TRUE(good.verdict.reliable) << good.verdict.first_failure();
  for (const char* name :
       {"finite", "frames", "turn", "monotone", "model", "pairs", "loop", "residuals", "extrinsics", "axis"})
    EXPECT_TRUE(std::any_of(good.verdict.checks.begin(), good.verdict.checks.end(), [&](const TrackingCheck& c) {
      return c.name == name;
    })) << name;
  ASSERT_EQ(good.verdict.frames.size(), scan_->frames.size());
  for (std::size_t s = 0; s < scan_->frames.size(); ++s)
    ASSERT_EQ(good.verdict.frames[s].size(), scan_->frames[s].size());
  const nlohmann::json stats = nlohmann::json::parse(tracking_stats_json(good, scan_->rig));
  EXPECT_TRUE(stats.at("verdict").at("reliable").get<bool>());
  EXPECT_EQ(stats.at("frame_support").at(scan_->rig.sensors[0].name).at("confidence").size(), scan_->frames[0].size());
  EXPECT_EQ(stats.at("frames").get<int>(), good.stats.frames);  // the count, not overwritten by the support

  // The observation counts and residuals the graph had (for re-verifying edited results).
  std::vector<std::vector<int>> observations(scan_->frames.size());
  for (std::size_t s = 0; s < scan_->frames.size(); ++s)
    for (const FrameSupport& f : good.verdict.frames[s]) observations[s].push_back(f.observations);
  const TrackingOptions options = test_tracking_options();
  auto failed = [&](const TrackingResult& r) {
    const TrackingVerdict v = verify_tracking(r, *scan_, *frontend_, observations, {}, options);
    std::vector<std::string> names;
    for (const TrackingCheck& c : v.checks)
      if (!c.passed) names.push_back(c.name);
    return names;
  };
  EXPECT_TRUE(failed(good).empty());
  auto contains = [](const std::vector<std::string>& names, const std::string& name) {
    return std::find(names.begin(), names.end(), name) != names.end();
  };

  // Every frame after the middle turned 40 deg further about the axis: the turn exceeds one
  // revolution, and the loop-closure pairs (end against start) disagree.
  TrackingResult turned = good;
  const Rigid3d& axis = good.trajectory.world_from_axis;
  const Rigid3d extra = axis * rotation_about(Eigen::Vector3d::UnitZ(), deg2rad(3)) * axis.inverse();
  for (std::size_t s = 0; s < scan_->frames.size(); ++s)
    for (std::size_t f = scan_->frames[s].size() / 2; f < scan_->frames[s].size(); ++f) {
      turned.trajectory.world_from_cam[s][f].world_from_cam =
          extra * turned.trajectory.world_from_cam[s][f].world_from_cam;
      turned.azimuth_unwrapped_rad[s][f] += deg2rad(40);
    }
  const std::vector<std::string> turned_failures = failed(turned);
  EXPECT_TRUE(contains(turned_failures, "turn"));
  EXPECT_TRUE(contains(turned_failures, "loop"));

  // Every other frame turned 3 deg about the axis: the turn and the azimuth's direction hold, but
  // the same-camera pairs' inliers no longer fit the tracked poses (the rotator's step is 6 deg).
  TrackingResult jittered = good;
  const Rigid3d jitter = axis * rotation_about(Eigen::Vector3d::UnitZ(), deg2rad(3)) * axis.inverse();
  for (std::size_t s = 0; s < scan_->frames.size(); ++s)
    for (std::size_t f = 1; f < scan_->frames[s].size(); f += 2) {
      jittered.trajectory.world_from_cam[s][f].world_from_cam =
          jitter * jittered.trajectory.world_from_cam[s][f].world_from_cam;
      jittered.azimuth_unwrapped_rad[s][f] += deg2rad(3);
    }
  const std::vector<std::string> jittered_failures = failed(jittered);
  EXPECT_TRUE(contains(jittered_failures, "pairs"));
  EXPECT_FALSE(contains(jittered_failures, "turn"));
  EXPECT_FALSE(contains(jittered_failures, "monotone"));
  // The same for one outer camera alone: pooled with the other cameras' pairs, 228 of 258 still agreed
  // (0.88); its own pairs do not.
  TrackingResult one_jittered = good;
  const std::size_t outer_sensor = scan_->rig.reference_sensor == 0 ? 1 : 0;
  for (std::size_t f = 1; f < scan_->frames[outer_sensor].size(); f += 2)
    one_jittered.trajectory.world_from_cam[outer_sensor][f].world_from_cam =
        jitter * one_jittered.trajectory.world_from_cam[outer_sensor][f].world_from_cam;
  const TrackingVerdict one = verify_tracking(one_jittered, *scan_, *frontend_, observations, {}, options);
  EXPECT_FALSE(one.reliable);
  EXPECT_EQ(one.first_failure().rfind("pairs:", 0), 0u) << one.first_failure();
  EXPECT_NE(one.first_failure().find(scan_->rig.sensors[outer_sensor].name + " alone"), std::string::npos)
      << one.first_failure();

  // Two reference frames swapped: the azimuth steps back.
  TrackingResult swapped = good;
  const int ref = scan_->rig.reference_sensor;
  std::swap(swapped.azimuth_unwrapped_rad[ref][10], swapped.azimuth_unwrapped_rad[ref][11]);
  std::swap(swapped.trajectory.world_from_cam[ref][10].world_from_cam,
            swapped.trajectory.world_from_cam[ref][11].world_from_cam);
  const std::vector<std::string> swapped_failures = failed(swapped);
  EXPECT_TRUE(contains(swapped_failures, "monotone"));

  // One frame 4 cm off the rotator model (as where a depth pair slid along a plain wall and the solve
  // followed it): the model check. The graph's own departures are all within it.
  ASSERT_EQ(good.model_departure_mm.size(), scan_->frames.size());
  double worst_sigma = 0.0;
  for (std::size_t s = 0; s < good.model_departure_mm.size(); ++s) {
    ASSERT_EQ(good.model_departure_mm[s].size(), scan_->frames[s].size());
    for (std::size_t f = 0; f < good.model_departure_mm[s].size(); ++f)
      worst_sigma =
          std::max(worst_sigma, std::hypot(good.model_departure_mm[s][f] / 5.0, good.model_departure_deg[s][f] / 0.5));
  }
  EXPECT_GT(worst_sigma, 0.0);
  EXPECT_LT(worst_sigma, options.verify.max_model_departure_sigma);
  TrackingResult departed = good;
  departed.model_departure_mm[ref][7] = 40.0;
  const std::vector<std::string> departed_failures = failed(departed);
  EXPECT_EQ(departed_failures, std::vector<std::string>{"model"});
  const TrackingVerdict departed_verdict = verify_tracking(departed, *scan_, *frontend_, observations, {}, options);
  EXPECT_NE(departed_verdict.first_failure().find(scan_->rig.sensors[ref].name + " frame 7 departs 40.0 mm"),
            std::string::npos)
      << departed_verdict.first_failure();

  // A wrong calibration: the estimated extrinsics 10 deg away from rig.json's.
  TrackingResult recalibrated = good;
  const int outer = ref == 0 ? 1 : 0;
  recalibrated.trajectory.ref_from_cam[outer] =
      recalibrated.trajectory.ref_from_cam[outer] * rotation_about(Eigen::Vector3d::UnitX(), deg2rad(10));
  EXPECT_TRUE(contains(failed(recalibrated), "extrinsics"));

  // No camera observed over half the turn: the frames check.
  std::vector<std::vector<int>> sparse = observations;
  for (auto& counts : sparse)
    for (std::size_t f = counts.size() / 4; f < 3 * counts.size() / 4; ++f) counts[f] = 0;
  // The paper's graph has no depth-odometry pairs: nothing holds the stretch.
  const TrackingVerdict gap = verify_tracking(good, *scan_, *frontend_, sparse, {}, options);
  EXPECT_FALSE(gap.reliable);
  EXPECT_EQ(gap.first_failure().rfind("frames:", 0), 0u) << gap.first_failure();
  // With the depth odometry, its pairs still measure the turn there (a plain wall does): they carry
  // the stretch.
  TrackingOptions depth_options = options;
  depth_options.depth_odometry = true;
  depth_options.verify.max_depth_yaw_std_deg = 0.1;
  const TrackingResult with_depth = track_with_frontend(*scan_, *frontend_, depth_options);
  const TrackingVerdict held_by_depth = verify_tracking(with_depth, *scan_, *frontend_, sparse, {}, depth_options);
  EXPECT_TRUE(held_by_depth.reliable) << held_by_depth.first_failure();
  int depth_supported = 0, frames = 0;
  for (const auto& camera : held_by_depth.frames)
    for (const FrameSupport& f : camera) {
      depth_supported += f.depth_supported;
      ++frames;
    }
  std::printf("frames supported by a depth pair's turn (std <= %.2f deg): %d of %d\n",
              depth_options.verify.max_depth_yaw_std_deg, depth_supported, frames);
  EXPECT_GT(depth_supported, frames / 2);
  // ... but not pairs the solution disagrees with (beyond the factor's Huber threshold): the solve
  // took them as outliers, and they do not hold what it made of the frame.
  TrackingResult disagreeing = with_depth;
  for (auto& pairs : disagreeing.depth_pair_residual) std::fill(pairs.begin(), pairs.end(), 10.0 * kDepthOdometryHuber);
  EXPECT_EQ(
      verify_tracking(disagreeing, *scan_, *frontend_, sparse, {}, depth_options).first_failure().rfind("frames:", 0),
      0u);
  // Without those pairs' turn (none measured, or the option at 0) the stretch is unsupported again.
  TrackingResult turn_unmeasured = with_depth;
  for (auto& pairs : turn_unmeasured.depth_yaw_std_deg)
    std::fill(pairs.begin(), pairs.end(), std::numeric_limits<double>::infinity());
  EXPECT_EQ(verify_tracking(turn_unmeasured, *scan_, *frontend_, sparse, {}, depth_options)
                .first_failure()
                .rfind("frames:", 0),
            0u);
  TrackingOptions landmarks_only = depth_options;
  landmarks_only.verify.max_depth_yaw_std_deg = 0;
  EXPECT_EQ(
      verify_tracking(with_depth, *scan_, *frontend_, sparse, {}, landmarks_only).first_failure().rfind("frames:", 0),
      0u);
  // A Refusal (not any Error): what `tables --record-refusals` records as a run's outcome.
  TrackingResult refused = good;
  refused.verdict = gap;
  EXPECT_THROW(require_reliable_tracking(refused, options, "scan"), Refusal);
}

TEST_F(TrackingTest, BadInputGivesClearErrors) {
  // Timestamps out of order in a listing: the scan reader names the file.
  const auto copy = dir_->path() / "unordered";
  std::filesystem::copy(scan_->root, copy, std::filesystem::copy_options::recursive);
  {
    std::ifstream in(copy / "cam1" / "rgb.txt");
    std::vector<std::string> lines;
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    std::swap(lines[lines.size() - 1], lines[lines.size() - 3]);
    std::ofstream out(copy / "cam1" / "rgb.txt");
    for (const auto& line : lines) out << line << "\n";
  }
  EXPECT_THROW(read_scan_index(copy), Error);
  // A reference camera without frames: a clear error, not a crash.
  ScanIndex empty_reference = *scan_;
  empty_reference.frames[scan_->rig.reference_sensor].clear();
  FrontendResult frontend = *frontend_;
  frontend.features[scan_->rig.reference_sensor].clear();
  EXPECT_THROW(track_with_frontend(empty_reference, frontend, test_tracking_options()), Error);
  // A non-reference camera without frames: left out with a warning, every other frame tracked.
  ScanIndex empty_top = *scan_;
  empty_top.frames[0].clear();
  FrontendResult frontend_top = *frontend_;
  frontend_top.features[0].clear();
  frontend_top.landmarks.clear();
  for (const auto& track : frontend_->landmarks) {
    std::vector<Observation> kept;
    for (const Observation& o : track)
      if (o.sensor != 0) kept.push_back(o);
    if (kept.size() >= 2) frontend_top.landmarks.push_back(kept);
  }
  TrackingOptions few_iterations = test_tracking_options();
  few_iterations.max_iterations = 3;
  const TrackingResult without_top = track_with_frontend(empty_top, frontend_top, few_iterations);
  EXPECT_TRUE(without_top.trajectory.world_from_cam[0].empty());
  EXPECT_EQ(without_top.trajectory.world_from_cam[1].size(), scan_->frames[1].size());
  EXPECT_FALSE(without_top.stats.converged);  // 3 iterations: reported, not hidden
  // Options out of range.
  TrackingOptions bad = test_tracking_options();
  bad.reg_translation_std_m = -1;
  EXPECT_THROW(bad.check(), Error);
}

}  // namespace
}  // namespace panoscan

namespace panoscan {
namespace {

// Mean over cameras of the ATE RMSE of a tracked scan against its ground truth.
double mean_ate(const std::filesystem::path& scan_dir, const TrackingResult& result) {
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan_dir);
  double sum = 0;
  for (std::size_t c = 0; c < truth.world_from_cam.size(); ++c)
    sum += eval::evaluate_trajectory(truth.world_from_cam[c], result.trajectory.world_from_cam[c],
                                     eval::TrajectoryMetricsOptions{}, "truth", "tracked")
               .ate_m.rmse;
  return sum / double(truth.world_from_cam.size());
}

TEST(TrackingSynchronisation, UnsynchronizedShuttersAreHandledAsWellAsSynchronizedOnes) {
  // The method must not rely on synchronisation: the same scan with all cameras triggered
  // together is not tracked better (beyond noise) than with random offsets and jitter.
  testutil::TempDir dir("tracking-sync");
  const Scene scene = scenes::make_builtin_scene("office", kIclStyle);
  SimOptions options = small_scan_options();
  options.output.every = 32;  // half the frames of the suite's scan: this test runs two scans
  double ate[2];
  for (int synchronized = 0; synchronized < 2; ++synchronized) {
    options.shutter.synchronized = synchronized == 1;
    const auto scan_dir = dir.path() / (synchronized ? "sync" : "unsync");
    Simulator(scene, 0, options).write_scan(scan_dir, false);
    const TrackingResult result = track_scan(read_scan_index(scan_dir), test_tracking_options());
    ate[synchronized] = mean_ate(scan_dir, result);
  }
  std::printf("ATE: unsynchronized %.2f mm, synchronized %.2f mm\n", ate[0] * 1e3, ate[1] * 1e3);
  EXPECT_GT(ate[1], 0.7 * ate[0]);
  EXPECT_LT(ate[0], 0.0085);  // measured 5.82 mm (synchronized 5.96 mm)
}

TEST(TrackingLoopClosure, LoopPairsThatMapAnObjectOntoItsTwinAreRejected) {
  // Generated office seed 3 has two identical workstations side by side. RANSAC verifies some loop
  // pairs that map one desk onto the other; the rotator checks of the front end (frontend.h, "A room
  // with repeated objects") must reject every such pair and keep loop closure. Each verified loop
  // pair is held against the truth: one whose translation misses the true relative pose by more
  // than 0.25 m maps an object onto another (valid pairs miss by up to 48 mm). Whether such a pair
  // bends the trajectory depends on the noise's realisation (one realisation: mean ATE 18.5 mm
  // without the checks and 4.5 mm with them; another: 6.3 against 4.4 mm), so the pairs are checked
  // one by one, over three simulation seeds, and the tracking with the checks on every seed.
  testutil::TempDir dir("tracking-twins");
  scenes::RoomSpec spec;
  spec.kind = scenes::RoomKind::kOffice;
  spec.seed = 3;
  const Scene scene = scenes::generate_room(spec).scene;
  TrackingOptions checked = test_tracking_options();
  FrontendOptions unchecked = checked.frontend;
  unchecked.max_pair_translation_m = 100.0;
  unchecked.loop_max_deviation_deg = 0.0;
  unchecked.loop_max_deviation_m = 0.0;
  int wrong = 0, wrong_kept = 0, right = 0, right_kept = 0;
  for (const std::uint64_t seed : {1, 2, 3}) {
    SimOptions options = small_scan_options();
    options.seed = seed;
    const auto scan_dir = dir.path() / ("scan" + std::to_string(seed));
    Simulator(scene, 0, options).write_scan(scan_dir, false);
    const ScanIndex scan = read_scan_index(scan_dir);
    const RigTrajectory truth = eval::groundtruth_rig_trajectory(scan_dir);
    const FrontendResult with_checks = run_frontend(scan, checked.frontend);
    const FrontendResult without_checks = run_frontend(scan, unchecked);
    EXPECT_EQ(without_checks.rejected_far_pairs + without_checks.rejected_loop_pairs, 0);
    std::set<std::array<int, 3>> kept;
    for (const FramePairMatch& pair : with_checks.pairs)
      if (pair.kind == FramePairMatch::Kind::kLoop) kept.insert({pair.sensor_a, pair.frame_a, pair.frame_b});
    int seed_wrong = 0, seed_right = 0;
    for (const FramePairMatch& pair : without_checks.pairs) {
      if (pair.kind != FramePairMatch::Kind::kLoop) continue;
      const Rigid3d true_a_from_b = truth.world_from_cam[pair.sensor_a][pair.frame_a].world_from_cam.inverse() *
                                    truth.world_from_cam[pair.sensor_b][pair.frame_b].world_from_cam;
      const double miss_m = (true_a_from_b.inverse() * pair.a_from_b).translation().norm();
      const bool is_kept = kept.count({pair.sensor_a, pair.frame_a, pair.frame_b}) > 0;
      if (miss_m > 0.25) {
        ++seed_wrong;
        wrong_kept += is_kept;
        EXPECT_FALSE(is_kept) << "seed " << seed << ": loop pair cam" << pair.sensor_a << " " << pair.frame_a << "-"
                              << pair.frame_b << " misses the truth by " << miss_m << " m and was kept";
      } else {
        ++seed_right;
        right_kept += is_kept;
      }
    }
    wrong += seed_wrong;
    right += seed_right;
    const TrackingResult tracked = track_with_frontend(scan, with_checks, checked);
    const double ate = mean_ate(scan_dir, tracked);
    std::printf(
        "seed %d: %d verified loop pairs map an object onto another, %d are right; with the checks %d far "
        "and %d loop pairs rejected, mean ATE %.2f mm\n",
        int(seed), seed_wrong, seed_right, with_checks.rejected_far_pairs, with_checks.rejected_loop_pairs, 1e3 * ate);
    EXPECT_LT(ate, 0.008) << "seed " << seed;
  }
  std::printf("wrong loop pairs kept: %d of %d; right ones kept: %d of %d\n", wrong_kept, wrong, right_kept, right);
  EXPECT_GT(wrong, 0);  // the room does what the test is for
  EXPECT_EQ(wrong_kept, 0);
  EXPECT_GT(right_kept, right / 2);  // loop closure stays
}

TEST(TrackingBand, TheOuterCamerasExtrinsicsComeFromTheOverlapBand) {
  // Pitches +-42 deg: about 11 px of overlap at 320x240 (less the cameras' 6-cm parallax). Band
  // alignment (frontend.band_*, src/cross_camera.h) finds the calibration's 0.5-deg error and
  // matches across the band; the tracking then releases the null-space prior of the outer cameras
  // and estimates their extrinsics from the data. Measured (office SO-1, n = 16, seed 1): 103 band
  // pairs, outer cameras 0.085 / 0.024 deg from the truth; without band matching 0.43 / 0.39 deg
  // (held near the calibration); with band matching but the null-space prior kept, 0.31 / 0.24 deg.
  testutil::TempDir dir("tracking-band");
  const Scene scene = scenes::make_builtin_scene("office", kIclStyle);
  SimOptions options = small_scan_options();
  options.seed = 1;
  options.rig.pitches_deg = {42.0, 0.0, -42.0};
  Simulator(scene, 0, options).write_scan(dir.path() / "scan", false);
  const ScanIndex scan = read_scan_index(dir.path() / "scan");
  const RigTrajectory truth = eval::groundtruth_rig_trajectory(dir.path() / "scan");
  TrackingOptions with_band = test_tracking_options();
  TrackingOptions without_band = with_band;
  without_band.frontend.band_matching = false;
  const TrackingResult tracked = track_scan(scan, with_band);
  const TrackingResult held = track_scan(scan, without_band);
  const auto errors = eval::extrinsics_errors(tracked.trajectory.ref_from_cam, truth.ref_from_cam);
  const auto held_errors = eval::extrinsics_errors(held.trajectory.ref_from_cam, truth.ref_from_cam);
  const CrossCameraFunnel& funnel = tracked.stats.cross_camera;
  std::printf("band: %d of %d frame pairs accepted, %lld matches; corrections %.2f / %.2f deg\n", funnel.band_accepted,
              funnel.band_candidates, funnel.band_matches, funnel.band_relations[0].correction_deg,
              funnel.band_relations[1].correction_deg);
  for (int c : {0, 2}) {
    std::printf("cam%d: %d cross-camera landmarks; extrinsics %.3f deg with the band, %.3f deg without\n", c,
                tracked.stats.cross_landmarks[c], errors[c].rotation_deg, held_errors[c].rotation_deg);
    EXPECT_TRUE(tracked.stats.extrinsics_observed[c]) << "cam" << c;
    EXPECT_FALSE(held.stats.extrinsics_observed[c]) << "cam" << c;
    EXPECT_LT(errors[c].rotation_deg, 0.2) << "cam" << c;
    EXPECT_GT(held_errors[c].rotation_deg, 0.3) << "cam" << c;
    // The first search found the calibration's error (0.5 deg, as simulated).
    EXPECT_NEAR(funnel.band_relations[c == 0 ? 0 : 1].correction_deg, 0.5, 0.2) << "cam" << c;
  }
  EXPECT_GE(funnel.band_accepted, 30);
  EXPECT_EQ(held.stats.cross_camera.band_accepted, 0);
  EXPECT_FALSE(tracked.stats.extrinsics_slide_held);

  // A released solve whose extrinsics fail the self-check is solved again with their slide along
  // the axis held at the calibration (TrackingOptions::hold_extrinsics_slide; office SL-2 seed 7
  // at 640x480 slid cam0 56 mm on its band landmarks). A limit of 0.1 mm fails any released solve:
  // the second solve must run, say so, and keep each camera's slide at the calibration.
  TrackingOptions strict = with_band;
  strict.verify.max_extrinsics_change_m = 1e-4;
  const TrackingResult retried = track_scan(scan, strict);
  EXPECT_TRUE(retried.stats.extrinsics_slide_held);
  EXPECT_NE(retried.stats.first_solve_failure.find("extrinsics"), std::string::npos)
      << retried.stats.first_solve_failure;
  // The axis in the reference camera's frame at its first frame (the rig frame up to the wobble).
  const int ref = scan.rig.reference_sensor;
  const Eigen::Vector3d axis_in_ref = tracked.trajectory.world_from_cam[ref][0].world_from_cam.linear().transpose() *
                                      tracked.trajectory.world_from_axis.linear().col(2);
  for (int c : {0, 2}) {
    const Eigen::Vector3d calibrated_t = scan.rig.sensors[c].ref_from_cam.translation();
    const double released_slide_mm =
        1e3 * axis_in_ref.dot(tracked.trajectory.ref_from_cam[c].translation() - calibrated_t);
    const double held_slide_mm = 1e3 * axis_in_ref.dot(retried.trajectory.ref_from_cam[c].translation() - calibrated_t);
    std::printf("cam%d: slide along the axis from the calibration %.2f mm released, %.3f mm held\n", c,
                released_slide_mm, held_slide_mm);
    EXPECT_LT(std::abs(held_slide_mm), 0.2) << "cam" << c;
  }
}

}  // namespace
}  // namespace panoscan
