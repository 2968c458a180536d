// Handheld recordings (issue 18 item 2): a one-camera sequence that walks and turns instead of
// rotating in place (the simulator's motion.kind = handheld, written with rig.json "motion":
// handheld, as `import tum` writes) tracks in ba-only and single-camera mode with no azimuth or
// axis assumptions; the rotator's modes are refused; and the same scan declared a rotator is
// refused by the self-check, so it is the handheld path that makes the result trustworthy.

#include <cstdio>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_util.h"
#include "panoscan/core/json_file.h"
#include "panoscan/core/scan.h"
#include "panoscan/core/trajectory.h"
#include "panoscan/eval/trajectory_metrics.h"
#include "panoscan/recon/tracking.h"
#include "panoscan/scenes/scenes.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

namespace panoscan {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int kThreads = 2;

SimOptions handheld_options(std::uint64_t seed) {
  SimOptions options;
  // 640x480: at 320x240 the ORB keypoints' localisation (0.5-1.8 px by octave) limits a walk's
  // ATE to 40-50 mm, which would hide a regression of the tracking itself.
  options.rig.width = 640;
  options.rig.height = 480;
  options.rig.pitches_deg = {0.0};  // one sensor, as a TUM sequence
  options.rig.reference_sensor = 0;
  options.motion.kind = MotionKind::kHandheld;
  options.motion.handheld_duration_s = 8.0;
  options.output.every = 4;  // 7.5 frames per second, 60 frames
  options.noise.preset = NoisePreset::kHanda;
  options.seed = seed;
  options.threads = kThreads;
  return options;
}

TrackingOptions tracking_options(TrackingMode mode) {
  TrackingOptions options;
  options.mode = mode;
  options.threads = kThreads;
  options.frontend.threads = kThreads;
  return options;
}

double ate_m(const fs::path& scan_dir, const TrackingResult& result) {
  const std::vector<StampedPose> truth = read_tum_trajectory(scan_dir / "groundtruth" / "cam0.txt");
  eval::TrajectoryMetricsOptions options;
  options.rpe_delta_s = 1.0;
  return eval::evaluate_trajectory(truth, result.trajectory.world_from_cam[0], options, "truth", "tracked").ate_m.rmse;
}

class HandheldTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testutil::TempDir("handheld");
    const Scene scene = scenes::make_builtin_scene("office", scenes::SceneStyle{scenes::TextureDensity::kIcl});
    Simulator(scene, 0, handheld_options(5)).write_scan(dir_->path() / "scan", false);
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static fs::path scan_dir() { return dir_->path() / "scan"; }
  static testutil::TempDir* dir_;
};
testutil::TempDir* HandheldTest::dir_ = nullptr;

TEST_F(HandheldTest, TheSimulatedWalkIsHandheldAndNotARotation) {
  const ScanIndex scan = read_scan_index(scan_dir());
  EXPECT_EQ(scan.rig.motion, RigMotion::kHandheld);
  ASSERT_EQ(scan.rig.sensors.size(), 1u);
  const std::vector<StampedPose> truth = read_tum_trajectory(scan_dir() / "groundtruth" / "cam0.txt");
  ASSERT_GE(truth.size(), 55u);
  // The camera centre wanders by decimetres (an in-place rotator moves it by its lever arm only,
  // on a circle) and the heading changes by tens of degrees without completing a turn.
  double max_offset = 0, max_angle_deg = 0;
  for (const StampedPose& p : truth) {
    const Rigid3d first_from_cam = truth.front().world_from_cam.inverse() * p.world_from_cam;
    max_offset = std::max(max_offset, first_from_cam.translation().norm());
    max_angle_deg = std::max(max_angle_deg, rad2deg(rotation_angle(first_from_cam.linear())));
  }
  std::printf("handheld walk: up to %.2f m and %.1f deg from the first pose\n", max_offset, max_angle_deg);
  EXPECT_GT(max_offset, 0.15);
  EXPECT_GT(max_angle_deg, 15.0);
  EXPECT_LT(max_angle_deg, 180.0);
  const nlohmann::json truth_json = read_json_file(scan_dir() / "groundtruth" / "rig_truth.json");
  EXPECT_EQ(truth_json.at("motion").at("kind"), "handheld");
}

TEST_F(HandheldTest, BaOnlyAndSingleCameraTrackWithoutRotatorAssumptions) {
  const ScanIndex scan = read_scan_index(scan_dir());
  for (TrackingMode mode : {TrackingMode::kBaOnly, TrackingMode::kSingleCamera}) {
    const TrackingResult result = track_scan(scan, tracking_options(mode));
    const double ate = ate_m(scan_dir(), result);
    std::printf("%s: ATE %.2f mm, %d landmarks, %d frames without observations, %s\n", to_string(mode), ate * 1e3,
                result.stats.landmarks, result.stats.frames_without_observations,
                result.verdict.reliable ? "reliable" : result.verdict.first_failure().c_str());
    EXPECT_TRUE(result.verdict.reliable) << result.verdict.first_failure();
    EXPECT_LT(ate, 0.015) << to_string(mode);  // measured 7.7 mm (seed 5; seed 6: 7.9 mm)
    EXPECT_EQ(result.stats.loop_pairs, 0);     // no end-of-turn loop closure on a walk
    EXPECT_EQ(result.stats.orb_levels, kHandheldOrbLevels);  // scale changes on a walk: ORB-SLAM2's 8 levels
    for (const TrackingCheck& check : result.verdict.checks) {
      EXPECT_NE(check.name, "turn");
      EXPECT_NE(check.name, "monotone");
      EXPECT_NE(check.name, "axis");
    }
  }
}

TEST_F(HandheldTest, DeclaredARotatorTheSameScanIsRefused) {
  // The feature removed: with the rotator's checks the walk fails (it does not turn one
  // revolution), so the handheld verdict above is not a check that passes anything.
  ScanIndex scan = read_scan_index(scan_dir());
  scan.rig.motion = RigMotion::kRotator;
  const TrackingResult result = track_scan(scan, tracking_options(TrackingMode::kBaOnly));
  EXPECT_FALSE(result.verdict.reliable);
  EXPECT_THAT(result.verdict.first_failure(), HasSubstr("turn"));
}

TEST_F(HandheldTest, TheRotatorModesAreRefusedNamingTheMotion) {
  const ScanIndex scan = read_scan_index(scan_dir());
  for (TrackingMode mode : {TrackingMode::kFull, TrackingMode::kFixedExtrinsics}) {
    const std::string message = testutil::error_of([&] { track_scan(scan, tracking_options(mode)); });
    EXPECT_THAT(message, HasSubstr("rig.json"));
    EXPECT_THAT(message, HasSubstr("motion"));
    EXPECT_THAT(message, HasSubstr("ba-only or single-camera"));
  }
}

TEST_F(HandheldTest, TheProgramTracksAndEvaluatesAHandheldScan) {
  const fs::path out = dir_->path() / "track";
  const auto track = testutil::run_panoscan("recon track --scan " + scan_dir().string() + " --out " + out.string() +
                                            " --mode ba-only --threads 2");
  ASSERT_EQ(track.exit_code, 0) << track.output;
  const auto traj = testutil::run_panoscan("eval traj --gt " + (scan_dir() / "groundtruth" / "cam0.txt").string() +
                                           " --est " + (out / "cam0.txt").string() + " --json " +
                                           (out / "traj.json").string());
  ASSERT_EQ(traj.exit_code, 0) << traj.output;
  const nlohmann::json figures = read_json_file(out / "traj.json");
  EXPECT_LT(figures.at("ate").at("rmse_m").get<double>(), 0.015);
  const auto full = testutil::run_panoscan("recon track --scan " + scan_dir().string() + " --out " +
                                           (dir_->path() / "full").string() + " --mode full --threads 2");
  EXPECT_EQ(full.exit_code, 2);
  EXPECT_THAT(full.output, HasSubstr("handheld"));
  // A walk has no panorama: the stage refuses rather than stitching one.
  const auto pano = testutil::run_panoscan("recon panorama --scan " + scan_dir().string() + " --poses " + out.string() +
                                           " --out " + (dir_->path() / "pano").string() + " --height 64");
  EXPECT_EQ(pano.exit_code, 2);
  EXPECT_THAT(pano.output, HasSubstr("rig.json: motion: handheld"));
}

TEST(HandheldMotion, SeededDeterministicAndStartsAtThePosition) {
  const Scene scene = scenes::make_builtin_scene("office", scenes::SceneStyle{scenes::TextureDensity::kIcl});
  const Simulator a(scene, 0, handheld_options(11)), b(scene, 0, handheld_options(11)), c(scene, 0, handheld_options(12));
  EXPECT_TRUE(a.motion().walk(0.0).isApprox(Rigid3d::Identity(), 1e-12));
  for (double t : {1.0, 3.7, 7.9}) {
    EXPECT_TRUE(a.world_from_cam(0, t).isApprox(b.world_from_cam(0, t), 0)) << t;
    EXPECT_FALSE(a.world_from_cam(0, t).isApprox(c.world_from_cam(0, t), 1e-6)) << t;
    EXPECT_EQ(a.motion().azimuth(t), 0.0);
  }
  EXPECT_DOUBLE_EQ(a.motion().duration(), 8.0);
}

}  // namespace
}  // namespace panoscan
