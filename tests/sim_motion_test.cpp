// Motion, shutters and ground-truth poses of the simulated rig (docs/ARCHITECTURE.md §6.3-6.4).
#include <algorithm>
#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "panoscan/sim/motion.h"
#include "panoscan/sim/shutter.h"
#include "panoscan/sim/simulator.h"
#include "test_util.h"

using namespace panoscan;

namespace {

double stddev(const std::vector<double>& values) {
  double mean = 0;
  for (double v : values) mean += v;
  mean /= values.size();
  double var = 0;
  for (double v : values) var += (v - mean) * (v - mean);
  return std::sqrt(var / values.size());
}

}  // namespace

TEST(Motion, TurnIsExactAndMonotonic) {
  MotionOptions options;
  const MotionModel motion(options, ScanPosition{}, 3);
  EXPECT_NEAR(motion.duration(), 33.0, 1e-9);  // 32 s per turn + one ramp
  EXPECT_NEAR(motion.azimuth(motion.duration()), 2 * M_PI, 1e-9);
  EXPECT_EQ(motion.azimuth(-1.0), 0.0);
  double previous = -1;
  for (double t = 0; t <= motion.duration(); t += 0.01) {
    const double a = motion.azimuth(t);
    ASSERT_GE(a, previous);
    previous = a;
  }
  // Cruise speed about 11.25 deg/s, with a few percent of slow variation.
  const double mid_speed = rad2deg(motion.angular_velocity(16.0));
  EXPECT_NEAR(mid_speed, 11.25, 1.5);
  // Starts and stops at rest.
  EXPECT_NEAR(motion.angular_velocity(0.0), 0.0, 1e-12);
  EXPECT_NEAR(motion.angular_velocity(motion.duration()), 0.0, 1e-12);
}

TEST(Motion, AzimuthIntegratesVelocityAndAccelerationIsItsDerivative) {
  const MotionModel motion(MotionOptions{}, ScanPosition{}, 5);
  for (double t : {0.3, 2.0, 10.0, 20.5, 32.7}) {
    const double h = 1e-4;
    EXPECT_NEAR((motion.azimuth(t + h) - motion.azimuth(t - h)) / (2 * h), motion.angular_velocity(t), 1e-6);
    EXPECT_NEAR((motion.angular_velocity(t + h) - motion.angular_velocity(t - h)) / (2 * h),
                motion.angular_acceleration(t), 1e-5);
  }
}

TEST(Motion, AccelerationAndWobbleHaveTheConfiguredStatistics) {
  MotionOptions options;
  options.accel_std_deg_s2 = 1.0;
  options.wobble_translation_m = 0.005;
  options.wobble_rotation_deg = 0.5;
  for (std::uint64_t seed : {1, 2, 3}) {
    const MotionModel motion(options, ScanPosition{}, seed);
    std::vector<double> acceleration;
    std::vector<double> components[6];
    for (double t = options.ramp_s; t < motion.duration() - options.ramp_s; t += 1.0 / 30) {
      acceleration.push_back(rad2deg(motion.angular_acceleration(t)));
      const Rigid3d w = motion.wobble(t);
      const Eigen::Vector3d r = so3_log(w.linear());
      for (int k = 0; k < 3; ++k) {
        components[k].push_back(w.translation()[k]);
        components[3 + k].push_back(rad2deg(r[k]));
      }
    }
    EXPECT_NEAR(stddev(acceleration), 1.0, 0.2) << "seed " << seed;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(stddev(components[k]), 0.005, 0.001) << "seed " << seed;
    for (int k = 3; k < 6; ++k) EXPECT_NEAR(stddev(components[k]), 0.5, 0.1) << "seed " << seed;
  }
}

TEST(Shutter, ThirtyHertzUnsynchronizedUniqueTimestamps) {
  ShutterOptions shutter;
  OutputOptions output;
  const auto schedule = make_frame_schedule(shutter, output, 3, 33.0, 11);
  std::set<long long> all;
  std::vector<double> first;
  for (const auto& frames : schedule) {
    ASSERT_GT(frames.size(), 950u);
    first.push_back(frames.front().timestamp);
    for (std::size_t i = 1; i < frames.size(); ++i) {
      const double dt = frames[i].timestamp - frames[i - 1].timestamp;
      // 30 Hz within the jitter bound (3 sigma each side) and the clock drift.
      ASSERT_NEAR(dt, 1.0 / 30, 6 * shutter.jitter_ms * 1e-3 + 1e-5);
    }
    const double mean_dt = (frames.back().timestamp - frames.front().timestamp) / (frames.size() - 1);
    EXPECT_NEAR(1.0 / mean_dt, 30.0, 30.0 * 1e-4);
    for (const auto& f : frames) {
      const long long us = std::llround(f.timestamp * 1e6);
      EXPECT_NEAR(f.timestamp * 1e6, double(us), 1e-3);  // whole microseconds
      ASSERT_TRUE(all.insert(us).second) << "timestamp shared: " << f.timestamp;
    }
  }
  // Start offsets are random within one frame interval and differ between cameras.
  for (double t : first) EXPECT_LT(t, 1.0 / 30 + 0.002);
  EXPECT_NE(first[0], first[1]);
  EXPECT_NE(first[1], first[2]);
}

TEST(Shutter, SynchronizedOptionTriggersAllCamerasTogether) {
  ShutterOptions shutter;
  shutter.synchronized = true;
  const auto schedule = make_frame_schedule(shutter, OutputOptions{}, 3, 5.0, 11);
  for (std::size_t k = 0; k < schedule[0].size(); ++k) {
    EXPECT_NE(schedule[0][k].timestamp, schedule[1][k].timestamp);  // still unique
    EXPECT_NEAR(schedule[0][k].timestamp, schedule[1][k].timestamp, 3e-6);
    EXPECT_NEAR(schedule[0][k].timestamp, schedule[2][k].timestamp, 3e-6);
  }
}

TEST(Shutter, EveryNKeepsTimestampsAndMaxFramesLimits) {
  ShutterOptions shutter;
  OutputOptions all_frames, sparse, limited;
  sparse.every = 7;
  limited.every = 7;
  limited.max_frames = 5;
  const auto dense = make_frame_schedule(shutter, all_frames, 3, 10.0, 4);
  const auto every7 = make_frame_schedule(shutter, sparse, 3, 10.0, 4);
  const auto five = make_frame_schedule(shutter, limited, 3, 10.0, 4);
  for (int c = 0; c < 3; ++c) {
    ASSERT_EQ(every7[c].size(), (dense[c].size() + 6) / 7);
    for (const auto& f : every7[c]) {
      ASSERT_EQ(f.index % 7, 0);
      EXPECT_EQ(f.timestamp, dense[c][f.index].timestamp);
    }
    ASSERT_EQ(five[c].size(), 5u);
    EXPECT_EQ(five[c][4].timestamp, every7[c][4].timestamp);
  }
}

class SimulatedPoses : public ::testing::Test {
 protected:
  SimulatedPoses() : scene_(testutil::make_box_room(-3, 3, -3, 3, 2.7, Eigen::Vector3d(0.2, -0.1, 0))) {
    options_.rig.width = 64;
    options_.rig.height = 48;
    options_.seed = 9;
  }
  Scene scene_;
  SimOptions options_;
};

TEST_F(SimulatedPoses, PosesFollowRotationPlusConfiguredWobble) {
  const Simulator sim(scene_, 0, options_);
  const RigModel& rig = sim.rig();
  const MotionModel& motion = sim.motion();
  for (int c = 0; c < 3; ++c) {
    std::vector<double> rotation[3], translation[3];
    for (const FrameTime& f : sim.schedule()[c]) {
      const double t = f.timestamp - options_.shutter.start_time_s;
      const Rigid3d ideal = motion.world_from_axis(t) * rig.axis_from_bracket * rig.bracket_from_cam[c];
      const Rigid3d deviation = ideal.inverse() * sim.world_from_cam(c, f.timestamp);  // Eq. 2's residual
      const Eigen::Vector3d r = so3_log(deviation.linear());
      for (int k = 0; k < 3; ++k) {
        rotation[k].push_back(rad2deg(r[k]));
        translation[k].push_back(deviation.translation()[k]);
      }
    }
    double rot_rms = 0, trans_rms = 0;
    for (int k = 0; k < 3; ++k) {
      rot_rms += std::pow(stddev(rotation[k]), 2);
      trans_rms += std::pow(stddev(translation[k]), 2);
    }
    // Per-axis std 0.5 deg / 5 mm (the lever arm of the camera on the bracket adds a little).
    EXPECT_NEAR(std::sqrt(rot_rms / 3), 0.5, 0.1) << "camera " << c;
    EXPECT_NEAR(std::sqrt(trans_rms / 3), 0.005, 0.001) << "camera " << c;
  }
}

TEST_F(SimulatedPoses, RotationAxisRecoveredFromGroundTruthPosesMatchesTheTruth) {
  options_.motion.axis_tilt_deg = 0.4;  // also check that the tilt is what the truth says
  const Simulator sim(scene_, 0, options_);
  const int c = 1;
  const auto& frames = sim.schedule()[c];
  // Direction: the mean rotation axis of relative rotations between frames about 120 deg apart
  // (many independent pairs, so that the wobble of any one frame does not bias the mean).
  std::vector<Rigid3d> poses;
  std::vector<Eigen::Vector3d> centres;
  for (const FrameTime& f : frames) {
    poses.push_back(sim.world_from_cam(c, f.timestamp));
    centres.push_back(poses.back().translation());
  }
  const std::size_t third = poses.size() / 3;
  Eigen::Vector3d axis_sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i + third < poses.size(); ++i) {
    const Eigen::Vector3d w = so3_log(poses[i + third].linear() * poses[i].linear().transpose());
    axis_sum += w.normalized();
  }
  Eigen::Vector3d axis = axis_sum.normalized();
  if (axis.z() < 0) axis = -axis;  // the turn is counter-clockwise about +z
  const double angle_error = rad2deg(std::acos(std::min(1.0, axis.dot(sim.motion().axis_direction()))));
  EXPECT_LT(angle_error, 0.1);
  // Position: circle fit of the camera centres in the plane orthogonal to the axis.
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  Eigen::MatrixXd a(centres.size(), 3);
  Eigen::VectorXd b(centres.size());
  for (std::size_t i = 0; i < centres.size(); ++i) {
    const double x = centres[i].dot(u), y = centres[i].dot(v);
    a.row(i) << 2 * x, 2 * y, 1;
    b[i] = x * x + y * y;
  }
  const Eigen::Vector3d fit = a.colPivHouseholderQr().solve(b);
  const Eigen::Vector3d point_on_axis = fit[0] * u + fit[1] * v;
  // Distance between the fitted axis line and the true one, measured at camera height.
  const Eigen::Vector3d true_point = sim.motion().axis_point();
  const Eigen::Vector3d true_dir = sim.motion().axis_direction();
  const Eigen::Vector3d at_height = true_point + true_dir * 1.1;
  const Eigen::Vector3d offset = at_height - point_on_axis;
  const double distance = (offset - offset.dot(axis) * axis).norm();
  EXPECT_LT(distance, 0.003);
  // The tilt from gravity is the configured one.
  EXPECT_NEAR(rad2deg(std::acos(true_dir.z())), 0.4, 1e-9);
}
