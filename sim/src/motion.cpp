#include "panoscan/sim/motion.h"

#include <algorithm>
#include <cmath>

#include "panoscan/core/random.h"

namespace panoscan {

namespace {

constexpr int kSpeedTerms = 8;
constexpr int kWobbleTerms = 12;

// Standard deviation of f over [begin, end], sampled every millisecond.
template <typename F>
double realised_std(F f, double begin, double end) {
  if (end <= begin) return 0.0;
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (double t = begin; t <= end; t += 1e-3, ++n) {
    const double v = f(t);
    sum += v;
    sum2 += v * v;
  }
  const double mean = sum / n;
  return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
}

}  // namespace

double MotionModel::sum(const std::vector<Sinusoid>& terms, double t) {
  double value = 0.0;
  for (const auto& s : terms) value += s.amplitude * std::sin(2.0 * M_PI * s.frequency_hz * t + s.phase);
  return value;
}

double MotionModel::sum_derivative(const std::vector<Sinusoid>& terms, double t) {
  double value = 0.0;
  for (const auto& s : terms) {
    const double omega = 2.0 * M_PI * s.frequency_hz;
    value += s.amplitude * omega * std::cos(omega * t + s.phase);
  }
  return value;
}

MotionModel::MotionModel(const MotionOptions& options, const ScanPosition& position, std::uint64_t seed)
    : options_(options), position_(position) {
  const Eigen::Vector3d tilt_axis(std::cos(deg2rad(options.axis_tilt_azimuth_deg)),
                                  std::sin(deg2rad(options.axis_tilt_azimuth_deg)), 0.0);
  world_from_axis_base_ = make_rigid(Eigen::Matrix3d::Identity(), position.floor_point) *
                          rotation_about(tilt_axis, deg2rad(options.axis_tilt_deg)) *
                          rotation_about(Eigen::Vector3d::UnitZ(), position.start_heading_rad);

  cruise_velocity_ = 2.0 * M_PI / options.period_s;
  const double turn = deg2rad(options.turn_deg);
  // Each raised-cosine ramp covers half the angle it would at cruise speed.
  duration_ = turn / cruise_velocity_ + options.ramp_s;
  if (options.kind == MotionKind::kHandheld) duration_ = options.handheld_duration_s;

  // Speed variation: e(t) = sum a sin(2 pi f t + phase); the random angular acceleration is
  // w_cruise * e'(t), whose variance is sum (a 2 pi f)^2 / 2. Equal amplitudes give the
  // configured acceleration std in expectation over the random phases.
  RandomStream speed_rng(seed, -1, 0, RandomPurpose::kMotion);
  double sum_f2 = 0.0;
  for (int k = 0; k < kSpeedTerms; ++k) {
    Sinusoid s{0.0, speed_rng.uniform(options.speed_band_low_hz, options.speed_band_high_hz),
               speed_rng.uniform(0.0, 2.0 * M_PI)};
    sum_f2 += s.frequency_hz * s.frequency_hz;
    speed_terms_.push_back(s);
  }
  const double accel_std = deg2rad(options.accel_std_deg_s2);
  const double amplitude = accel_std / (cruise_velocity_ * 2.0 * M_PI * std::sqrt(sum_f2 / 2.0));
  for (auto& s : speed_terms_) s.amplitude = amplitude;
  // A few sinusoids over ~30 s do not average their cross terms away: rescale so that the
  // realised std over the cruise phase is the configured one, whatever the seed.
  const double realised = realised_std([&](double t) { return cruise_velocity_ * sum_derivative(speed_terms_, t); },
                                       options.ramp_s, duration_ - options.ramp_s);
  if (realised > 0)
    for (auto& s : speed_terms_) s.amplitude *= accel_std / realised;

  // Wobble: per component the same construction; std = a * sqrt(K / 2).
  for (int component = 0; component < 6; ++component) {
    RandomStream rng(seed, -1, component, RandomPurpose::kWobble);
    const double stddev = component < 3 ? options.wobble_translation_m : deg2rad(options.wobble_rotation_deg);
    const double a = stddev * std::sqrt(2.0 / kWobbleTerms);
    for (int k = 0; k < kWobbleTerms; ++k)
      wobble_terms_[component].push_back(
          {a, rng.uniform(options.wobble_band_low_hz, options.wobble_band_high_hz), rng.uniform(0.0, 2.0 * M_PI)});
    const double realised = realised_std([&](double t) { return sum(wobble_terms_[component], t); }, 0.0, duration_);
    if (realised > 0)
      for (auto& s : wobble_terms_[component]) s.amplitude *= stddev / realised;
  }

  if (options.kind == MotionKind::kHandheld) {
    const double stds[6] = {options.handheld_translation_m, options.handheld_translation_m,
                            options.handheld_height_m,      deg2rad(options.handheld_yaw_deg),
                            deg2rad(options.handheld_tilt_deg), deg2rad(options.handheld_tilt_deg)};
    constexpr int kWalkTerms = 8;
    for (int component = 0; component < 6; ++component) {
      RandomStream rng(seed, -1, 100 + component, RandomPurpose::kMotion);
      for (int k = 0; k < kWalkTerms; ++k)
        walk_terms_[component].push_back(
            {1.0, rng.uniform(options.handheld_band_low_hz, options.handheld_band_high_hz),
             rng.uniform(0.0, 2.0 * M_PI)});
      // Exactly the configured std over the recording, whatever the seed (as the wobble).
      const double realised = realised_std([&](double t) { return sum(walk_terms_[component], t); }, 0.0, duration_);
      for (auto& s : walk_terms_[component]) s.amplitude = realised > 0 ? stds[component] / realised : 0.0;
    }
    cruise_velocity_ = 0.0;  // no turn: azimuth(t) = 0
    azimuth_table_.assign(2, 0.0);
    scale_ = 0.0;
    return;
  }

  // Integrate the raw velocity (trapezoid, 1 ms) and scale it so the turn is exact.
  const std::size_t steps = static_cast<std::size_t>(std::ceil(duration_ / table_step_)) + 1;
  azimuth_table_.assign(steps + 1, 0.0);
  double previous = raw_velocity(0.0);
  for (std::size_t i = 1; i <= steps; ++i) {
    const double v = raw_velocity(i * table_step_);
    azimuth_table_[i] = azimuth_table_[i - 1] + 0.5 * (previous + v) * table_step_;
    previous = v;
  }
  scale_ = 1.0;
  scale_ = turn / azimuth(duration_);
}

double MotionModel::ramp(double t) const {
  if (t <= 0.0 || t >= duration_) return 0.0;
  const double r = options_.ramp_s;
  if (r <= 0.0) return 1.0;
  if (t < r) return 0.5 * (1.0 - std::cos(M_PI * t / r));
  if (t > duration_ - r) return 0.5 * (1.0 - std::cos(M_PI * (duration_ - t) / r));
  return 1.0;
}

double MotionModel::ramp_derivative(double t) const {
  const double r = options_.ramp_s;
  if (t <= 0.0 || t >= duration_ || r <= 0.0) return 0.0;
  if (t < r) return 0.5 * M_PI / r * std::sin(M_PI * t / r);
  if (t > duration_ - r) return -0.5 * M_PI / r * std::sin(M_PI * (duration_ - t) / r);
  return 0.0;
}

double MotionModel::raw_velocity(double t) const { return cruise_velocity_ * ramp(t) * (1.0 + sum(speed_terms_, t)); }

double MotionModel::azimuth(double t) const {
  if (t <= 0.0) return 0.0;
  const double clamped = std::min(t, duration_);
  const std::size_t i = std::min(static_cast<std::size_t>(clamped / table_step_), azimuth_table_.size() - 1);
  const double ti = i * table_step_;
  // Table value plus the trapezoid over the remaining fraction of a step.
  const double partial = 0.5 * (raw_velocity(ti) + raw_velocity(clamped)) * (clamped - ti);
  return scale_ * (azimuth_table_[i] + partial);
}

double MotionModel::angular_velocity(double t) const { return scale_ * raw_velocity(t); }

double MotionModel::angular_acceleration(double t) const {
  return scale_ * cruise_velocity_ *
         (ramp_derivative(t) * (1.0 + sum(speed_terms_, t)) + ramp(t) * sum_derivative(speed_terms_, t));
}

Rigid3d MotionModel::world_from_axis(double t) const {
  if (options_.kind == MotionKind::kHandheld) return world_from_axis_base_ * walk(t);
  return world_from_axis_base_ * rotation_about(Eigen::Vector3d::UnitZ(), azimuth(t));
}

Rigid3d MotionModel::walk(double t) const {
  if (options_.kind != MotionKind::kHandheld) return Rigid3d::Identity();
  double v[6];
  for (int k = 0; k < 6; ++k) v[k] = sum(walk_terms_[k], t) - sum(walk_terms_[k], 0.0);  // 0 at the start
  return make_rigid(Eigen::Matrix3d::Identity(), Eigen::Vector3d(v[0], v[1], v[2])) *
         rotation_about(Eigen::Vector3d::UnitZ(), v[3]) * rotation_about(Eigen::Vector3d::UnitY(), v[4]) *
         rotation_about(Eigen::Vector3d::UnitX(), v[5]);
}

Rigid3d MotionModel::wobble(double t) const {
  const Eigen::Vector3d translation(sum(wobble_terms_[0], t), sum(wobble_terms_[1], t), sum(wobble_terms_[2], t));
  const Eigen::Vector3d rotation(sum(wobble_terms_[3], t), sum(wobble_terms_[4], t), sum(wobble_terms_[5], t));
  return make_rigid(so3_exp(rotation), translation);
}

Eigen::Vector3d MotionModel::axis_direction() const { return world_from_axis_base_.linear().col(2); }
Eigen::Vector3d MotionModel::axis_point() const { return world_from_axis_base_.translation(); }

}  // namespace panoscan
