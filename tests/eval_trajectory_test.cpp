// Trajectory errors against values known in closed form: ATE 0 for a rigidly moved copy, a
// zigzag perturbation that the alignment cannot absorb (ATE = its amplitude, RPE = twice it), a
// rotation drift (RPE rotation = rate x delta); association tolerance; axis, extrinsics and
// pose errors; bad input.

#include <cmath>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/eval/pose_error.h"
#include "panoscan/eval/trajectory_metrics.h"

namespace panoscan::eval {
namespace {

using ::testing::HasSubstr;

constexpr int kPoses = 300;  // one full turn, 10 s at 30 Hz

// A camera on a circle of radius 0.1 m at 1.1 m height, looking outwards, one turn in 10 s.
std::vector<StampedPose> circle_trajectory() {
  std::vector<StampedPose> poses;
  for (int i = 0; i < kPoses; ++i) {
    const double angle = 2 * M_PI * i / kPoses;
    StampedPose pose;
    pose.timestamp = 100.0 + i / 30.0;
    // Camera z (forward) horizontal and outwards, y down, x = y cross z (right-handed).
    const Eigen::Vector3d forward(std::cos(angle), std::sin(angle), 0.0), down(0, 0, -1);
    Eigen::Matrix3d world_from_cam_rotation;
    world_from_cam_rotation.col(0) = down.cross(forward);
    world_from_cam_rotation.col(1) = down;
    world_from_cam_rotation.col(2) = forward;
    pose.world_from_cam =
        make_rigid(world_from_cam_rotation, Eigen::Vector3d(0.1 * std::cos(angle), 0.1 * std::sin(angle), 1.1));
    poses.push_back(pose);
  }
  return poses;
}

TEST(Trajectory, RigidlyMovedCopyHasZeroError) {
  const std::vector<StampedPose> gt = circle_trajectory();
  ASSERT_NEAR(gt[7].world_from_cam.linear().determinant(), 1.0, 1e-12);
  const Rigid3d moved = make_rigid(so3_exp(Eigen::Vector3d(0.3, -0.2, 1.1)), Eigen::Vector3d(2.0, -1.0, 0.5));
  std::vector<StampedPose> est = gt;
  for (auto& pose : est) pose.world_from_cam = moved * pose.world_from_cam;
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, {}, "gt.txt", "est.txt");
  EXPECT_EQ(m.matched_poses, std::size_t(kPoses));
  EXPECT_LT(m.ate_m.rmse, 1e-9);
  EXPECT_LT(m.ate_m.max, 1e-9);
  EXPECT_LT(m.ate_rotation_deg.max, 1e-6);
  EXPECT_LT(m.rpe_translation_m.max, 1e-9);
  EXPECT_LT(m.rpe_rotation_deg.max, 1e-6);
  EXPECT_TRUE((m.gt_from_est * moved).matrix().isApprox(Eigen::Matrix4d::Identity(), 1e-9));
  EXPECT_EQ(m.rpe_translation_m.count, std::size_t(kPoses - 30));  // delta 1 s = 30 frames
}

TEST(Trajectory, ZigzagPerturbationGivesKnownAteAndRpe) {
  // est_i = gt_i moved by (-1)^i * a along z. Over a full circle sampled an even number of times the
  // perturbation is uncorrelated with the positions, so the optimal alignment is the identity
  // and ATE = a exactly. Over an odd number of frames the RPE translation is |e_j - e_i| = 2a.
  const double a = 0.005;
  const std::vector<StampedPose> gt = circle_trajectory();
  std::vector<StampedPose> est = gt;
  for (int i = 0; i < kPoses; ++i) est[i].world_from_cam.translation().z() += (i % 2 ? -a : a);
  TrajectoryMetricsOptions options;
  options.rpe_delta_s = 0.1;  // 3 frames
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, options, "gt.txt", "est.txt");
  EXPECT_NEAR(m.ate_m.rmse, a, 1e-12);
  EXPECT_NEAR(m.ate_m.mean, a, 1e-12);
  EXPECT_NEAR(m.ate_m.max, a, 1e-12);
  EXPECT_NEAR(m.rpe_translation_m.rmse, 2 * a, 1e-12);
  EXPECT_NEAR(m.rpe_translation_m.max, 2 * a, 1e-12);
  EXPECT_LT(m.rpe_rotation_deg.max, 1e-9);
  EXPECT_EQ(m.rpe_translation_m.count, std::size_t(kPoses - 3));
  // Over an even number of frames the zigzag cancels.
  options.rpe_delta_s = 0.2;
  EXPECT_LT(evaluate_trajectory(gt, est, options, "gt.txt", "est.txt").rpe_translation_m.max, 1e-12);
}

TEST(Trajectory, RotationDriftGivesKnownRpe) {
  // gt_i rotates about the camera x axis and moves along world x; est_i = gt_i * Rx(omega t_i).
  // Everything commutes about x, so E_ij = Rx(omega (t_j - t_i)) with no translation: the rotational
  // RPE is omega * delta exactly, and the positions (hence the ATE) are untouched.
  std::vector<StampedPose> gt;
  for (int i = 0; i < kPoses; ++i) {
    StampedPose pose;
    pose.timestamp = i / 30.0;
    pose.world_from_cam = make_rigid(so3_exp(Eigen::Vector3d(0.02 * i, 0, 0)), Eigen::Vector3d(0.01 * i, 0, 0));
    gt.push_back(pose);
  }
  const double omega = deg2rad(2.0);  // 2 deg/s
  std::vector<StampedPose> est = gt;
  for (auto& pose : est)
    pose.world_from_cam = pose.world_from_cam * rotation_about(Eigen::Vector3d::UnitX(), omega * pose.timestamp);
  TrajectoryMetricsOptions options;
  options.rpe_delta_s = 1.0;
  const TrajectoryMetrics m = evaluate_trajectory(gt, est, options, "gt", "est");
  EXPECT_LT(m.ate_m.max, 1e-9);
  EXPECT_NEAR(m.rpe_rotation_deg.mean, 2.0, 1e-9);
  EXPECT_NEAR(m.rpe_rotation_deg.max, 2.0, 1e-9);
  EXPECT_LT(m.rpe_translation_m.max, 1e-9);
}

TEST(Trajectory, AssociationTolerance) {
  const std::vector<StampedPose> gt = circle_trajectory();
  std::vector<StampedPose> est = gt;
  for (auto& pose : est) pose.timestamp += 5e-5;  // within the default 0.1 ms
  EXPECT_EQ(associate_by_timestamp(gt, est, 1e-4).size(), std::size_t(kPoses));
  for (auto& pose : est) pose.timestamp += 1e-3;
  EXPECT_TRUE(associate_by_timestamp(gt, est, 1e-4).empty());
  EXPECT_EQ(associate_by_timestamp(gt, est, 2e-3).size(), std::size_t(kPoses));
  try {
    evaluate_trajectory(gt, est, {}, "groundtruth/cam0.txt", "tracked/cam0.txt");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("groundtruth/cam0.txt"));
    EXPECT_THAT(e.what(), HasSubstr("tracked/cam0.txt"));
    EXPECT_THAT(e.what(), HasSubstr("no common timestamps"));
  }
  // Every other estimated pose: half of them match.
  std::vector<StampedPose> sparse;
  for (int i = 0; i < kPoses; i += 2) sparse.push_back(gt[i]);
  EXPECT_EQ(evaluate_trajectory(gt, sparse, {}, "gt", "est").matched_poses, std::size_t(kPoses / 2));
}

TEST(Trajectory, BadInput) {
  const std::vector<StampedPose> gt = circle_trajectory();
  EXPECT_THROW(evaluate_trajectory(gt, {}, {}, "gt", "est"), Error);
  std::vector<StampedPose> two(gt.begin(), gt.begin() + 2);
  EXPECT_THAT(
      [&] {
        try {
          evaluate_trajectory(gt, two, {}, "gt", "est.txt");
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("at least 3"));
  std::vector<StampedPose> short_est(gt.begin(), gt.begin() + 10);  // 0.3 s < 1 s delta
  EXPECT_THAT(
      [&] {
        try {
          evaluate_trajectory(gt, short_est, {}, "gt", "est.txt");
        } catch (const Error& e) {
          return std::string(e.what());
        }
        return std::string();
      }(),
      HasSubstr("est.txt"));
  std::vector<StampedPose> unordered = gt;
  std::swap(unordered[4], unordered[5]);
  EXPECT_THROW(evaluate_trajectory(gt, unordered, {}, "gt", "est"), Error);
  TrajectoryMetricsOptions bad;
  bad.rpe_delta_s = 0;
  EXPECT_THROW(evaluate_trajectory(gt, gt, bad, "gt", "est"), Error);
}

TEST(PoseError, KnownRotationAndTranslation) {
  const Rigid3d truth = make_rigid(so3_exp(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(0.1, 0.2, 0.3));
  Rigid3d estimated = truth * rotation_about(Eigen::Vector3d(1, 1, 0), deg2rad(2.0));
  estimated.translation() += Eigen::Vector3d(0.003, 0.0, -0.004);
  const PoseError error = pose_error(estimated, truth);
  EXPECT_NEAR(error.rotation_deg, 2.0, 1e-9);
  EXPECT_NEAR(error.translation_m, 0.005, 1e-12);

  const std::vector<PoseError> extrinsics = extrinsics_errors({truth, estimated}, {truth, truth});
  ASSERT_EQ(extrinsics.size(), 2u);
  EXPECT_NEAR(extrinsics[0].rotation_deg, 0.0, 1e-9);
  EXPECT_NEAR(extrinsics[1].translation_m, 0.005, 1e-12);
  EXPECT_THROW(extrinsics_errors({truth}, {truth, truth}), Error);
}

TEST(AxisError, TiltedShiftedAndParallelAxes) {
  const Line3d truth{{0, 0, 0}, {0, 0, 1}};
  // Tilted by 1 deg about x and shifted 1 cm along x: skew lines 1 cm apart.
  const Line3d tilted{{0.01, 0, 0}, {0, -std::sin(deg2rad(1.0)), std::cos(deg2rad(1.0))}};
  AxisError e = axis_error(tilted, truth);
  EXPECT_NEAR(e.angle_deg, 1.0, 1e-9);
  EXPECT_NEAR(e.line_distance_m, 0.01, 1e-12);
  EXPECT_NEAR(e.offset_at_reference_m, 0.01, 1e-12);
  // Parallel, 2 cm apart; a flipped direction is the same line.
  e = axis_error({{0.0, 0.02, 5.0}, {0, 0, -3}}, truth);
  EXPECT_NEAR(e.angle_deg, 0.0, 1e-12);
  EXPECT_NEAR(e.line_distance_m, 0.02, 1e-12);
  // Tilted through the reference point: no offset there, and the lines intersect.
  e = axis_error({{0, 0, 0}, {std::sin(deg2rad(0.5)), 0, std::cos(deg2rad(0.5))}}, truth);
  EXPECT_NEAR(e.angle_deg, 0.5, 1e-9);
  EXPECT_NEAR(e.line_distance_m, 0.0, 1e-12);
  // From a pose: the axis frame's z axis through its origin.
  const Line3d from_pose = axis_line(make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.03, 0.04, 1.0)));
  EXPECT_NEAR(axis_error(from_pose, truth).offset_at_reference_m, 0.05, 1e-12);
  EXPECT_THROW(axis_error({{0, 0, 0}, {0, 0, 0}}, truth), Error);
}

}  // namespace
}  // namespace panoscan::eval
