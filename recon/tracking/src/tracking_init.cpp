#include "tracking_init.h"

#include <cmath>

#include <Eigen/Dense>

namespace panoscan::tracking_init {

namespace {

// The left Jacobian of SO(3) at the rotation vector w (V in exp([w, u]) = [exp(w), V u]).
Eigen::Matrix3d left_jacobian(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  Eigen::Matrix3d hat;
  hat << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  if (angle < 1e-4) return Eigen::Matrix3d::Identity() + 0.5 * hat + hat * hat / 6.0;  // the series
  return Eigen::Matrix3d::Identity() + (1 - std::cos(angle)) / (angle * angle) * hat +
         (angle - std::sin(angle)) / (angle * angle * angle) * hat * hat;
}

// exp(fraction log(step)): the screw motion `step` carried on to `fraction` of itself (negative:
// backwards). A rotation about an offset axis, as an in-place rotator's, stays on its circle.
Rigid3d scaled_motion(const Rigid3d& step, double fraction) {
  const Eigen::AngleAxisd rotation(step.linear());
  const Eigen::Vector3d w = rotation.angle() * rotation.axis();
  const Eigen::Vector3d u = left_jacobian(w).inverse() * step.translation();
  Rigid3d scaled = Rigid3d::Identity();
  scaled.linear() = Eigen::AngleAxisd(rotation.angle() * fraction, rotation.axis()).toRotationMatrix();
  scaled.translation() = left_jacobian(fraction * w) * (fraction * u);
  return scaled;
}

// Frames before the first verified pair (a turn that starts facing a plain wall) have nothing to
// chain from, and the loop left them at frame 0's pose: the first verified frame then started the
// rest of the turn where frame 0 was, as though the rotator had stood still, and the solver did not
// turn the whole chain with its landmarks back along that weakly determined direction (a generated
// living room lost 23 deg that way). Instead the first verified motion is carried back in time to
// frame 0 at its rate (constant velocity, as the loop does forward), and the chain is re-anchored at
// frame 0.
void extrapolate_leading_gap(const std::vector<FrameFeatures>& frames, const std::vector<int>& previous,
                             std::vector<Rigid3d>* world_from_cam) {
  const int n = int(world_from_cam->size());
  int first = 1;
  while (first < n && previous[std::size_t(first)] < 0) ++first;
  if (first >= n) return;
  const int start = previous[std::size_t(first)];  // the first frame of the chained stretch
  const double span = frames[std::size_t(first)].timestamp - frames[std::size_t(start)].timestamp;
  if (start == 0 && first == 1) return;
  if (!(span > 0)) return;
  std::vector<Rigid3d>& poses = *world_from_cam;
  const Rigid3d start_pose = poses[std::size_t(start)];
  const Rigid3d step = start_pose.inverse() * poses[std::size_t(first)];
  for (int f = 0; f < first; ++f) {
    if (f == start) continue;
    const double fraction = (frames[std::size_t(f)].timestamp - frames[std::size_t(start)].timestamp) / span;
    poses[std::size_t(f)] = start_pose * scaled_motion(step, fraction);
  }
  const Rigid3d frame0_from_world = poses.front().inverse();
  for (Rigid3d& pose : poses) pose = frame0_from_world * pose;
}

}  // namespace

std::vector<Rigid3d> chain_odometry(const FrontendResult& frontend, int sensor, int* verified) {
  const int n = int(frontend.features[sensor].size());
  // previous_from_current[f]: the verified pair (g, f) with the largest g < f.
  std::vector<int> previous(n, -1);
  std::vector<Rigid3d> previous_from_current(n, Rigid3d::Identity());
  for (const FramePairMatch& pair : frontend.pairs) {
    if (pair.kind != FramePairMatch::Kind::kSameCamera || pair.sensor_a != sensor || pair.sensor_b != sensor) continue;
    if (pair.frame_b <= pair.frame_a) continue;
    if (pair.frame_a > previous[pair.frame_b]) {
      previous[pair.frame_b] = pair.frame_a;
      previous_from_current[pair.frame_b] = pair.a_from_b;
    }
  }
  std::vector<Rigid3d> world_from_cam(n, Rigid3d::Identity());
  Rigid3d last_step = Rigid3d::Identity();
  int count = 0;
  for (int f = 1; f < n; ++f) {
    if (previous[f] >= 0) {
      world_from_cam[f] = world_from_cam[previous[f]] * previous_from_current[f];
      last_step = world_from_cam[f - 1].inverse() * world_from_cam[f];
      ++count;
    } else {
      world_from_cam[f] = world_from_cam[f - 1] * last_step;
    }
  }
  if (verified) *verified = count;
  extrapolate_leading_gap(frontend.features[sensor], previous, &world_from_cam);
  return world_from_cam;
}

AxisEstimate fit_axis(const std::vector<Rigid3d>& world_from_cam, double min_rotation_rad) {
  AxisEstimate axis;
  const Rigid3d& first = world_from_cam.front();
  axis.point = first.translation();
  axis.direction = -first.linear().col(1);  // camera "up" (y points down)
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Vector3d sign_reference = Eigen::Vector3d::Zero();
  std::vector<Rigid3d> relative;
  for (const Rigid3d& pose : world_from_cam) {
    const Rigid3d first_from_cam = first.inverse() * pose;
    const Eigen::Vector3d rotation_vector = so3_log(first_from_cam.linear());
    const double angle = rotation_vector.norm();
    if (angle < min_rotation_rad || angle > M_PI - 0.2) continue;
    Eigen::Vector3d unit = rotation_vector / angle;
    if (sign_reference.isZero()) sign_reference = unit;
    if (unit.dot(sign_reference) < 0) unit = -unit;
    sum += unit;
    relative.push_back(first_from_cam);
  }
  if (relative.size() < 2) return axis;
  const Eigen::Vector3d direction_in_first = sum.normalized();
  // Fixed point: R p + t = p for a rotation about an axis through p; plus the row d . p = 0
  // (the point closest to the first camera centre, the origin of the first frame).
  Eigen::Matrix3d normal = direction_in_first * direction_in_first.transpose();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (const Rigid3d& pose : relative) {
    const Eigen::Matrix3d a = Eigen::Matrix3d::Identity() - pose.linear();
    normal += a.transpose() * a;
    rhs += a.transpose() * pose.translation();
  }
  const Eigen::Vector3d point_in_first = normal.ldlt().solve(rhs);
  axis.point = first * point_in_first;
  axis.direction = first.linear() * direction_in_first;
  axis.from_rotation = true;
  return axis;
}

double twist_angle(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& axis) {
  const Eigen::Quaterniond q(rotation);
  return wrap_pi(2.0 * std::atan2(q.vec().dot(axis.normalized()), q.w()));
}

}  // namespace panoscan::tracking_init
