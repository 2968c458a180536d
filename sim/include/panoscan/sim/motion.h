// The wobbling in-place rotator (docs/ARCHITECTURE.md §6.3).
//
// world_from_axis(t) = T(floor_point) * Tilt * Rz(start_heading + azimuth(t)): the ideal pose.
// world_from_bracket(t) = world_from_axis(t) * axis_from_bracket * Wobble(t), the wobble being a
// band-limited 6-DoF perturbation of the bracket about its own origin (so the deviation of each
// camera from its ideal pose has the configured std, as the paper's Eq. 2 models it).
// Angular velocity: w(t) = w_cruise * ramp(t) * (1 + e(t)), e(t) a sum of sinusoids (random
// frequencies in the speed band, random phases) whose derivative has, over the cruise phase,
// exactly the std accel_std / w_cruise; w is then rescaled (by < 1%) so the total turn is exact.
// Each wobble component is a sum of 12 sinusoids in the wobble band with exactly the configured
// std over the scan: band-limited, so consecutive frames are correlated as real vibration is.
// Handheld (motion.kind): no turn (azimuth 0); world_from_axis(t) = that start pose * Walk(t), the
// walk a smooth 6-DoF excursion (x, y, z, yaw, pitch, roll, each a sum of 8 sinusoids in the
// handheld band with exactly the configured std, shifted to be 0 at t = 0), the wobble on top.
#pragma once

#include <vector>

#include "panoscan/core/geometry.h"
#include "panoscan/core/mesh.h"
#include "panoscan/sim/options.h"

namespace panoscan {

class MotionModel {
 public:
  MotionModel(const MotionOptions& options, const ScanPosition& position, std::uint64_t seed);

  double duration() const { return duration_; }  // seconds from start to stop
  double azimuth(double t) const;                // radians, 0 at t <= 0, turn at t >= duration
  double angular_velocity(double t) const;       // rad/s
  double angular_acceleration(double t) const;   // rad/s^2 (analytic)
  Rigid3d world_from_axis(double t) const;       // ideal, no wobble
  Rigid3d wobble(double t) const;                // bracket perturbation
  Rigid3d walk(double t) const;                  // handheld excursion from the start pose (identity on the rotator)
  // Unit axis direction and a point on it, in the scene frame.
  Eigen::Vector3d axis_direction() const;
  Eigen::Vector3d axis_point() const;

 private:
  struct Sinusoid {
    double amplitude, frequency_hz, phase;
  };
  static double sum(const std::vector<Sinusoid>& terms, double t);
  static double sum_derivative(const std::vector<Sinusoid>& terms, double t);
  double ramp(double t) const;
  double ramp_derivative(double t) const;
  double raw_velocity(double t) const;  // before the turn-exact scaling

  MotionOptions options_;
  ScanPosition position_;
  Rigid3d world_from_axis_base_ = Rigid3d::Identity();  // translation + tilt + start heading
  double cruise_velocity_ = 0.0;
  double duration_ = 0.0;
  double scale_ = 1.0;
  std::vector<Sinusoid> speed_terms_;
  std::vector<Sinusoid> wobble_terms_[6];
  std::vector<Sinusoid> walk_terms_[6];  // handheld: x, y, z (m), yaw, pitch, roll (rad)
  std::vector<double> azimuth_table_;  // azimuth sampled every table_step_ seconds
  double table_step_ = 1e-3;
};

}  // namespace panoscan
