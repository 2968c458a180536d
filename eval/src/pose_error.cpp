#include "panoscan/eval/pose_error.h"

#include <cmath>

#include "panoscan/core/error.h"

namespace panoscan::eval {

PoseError pose_error(const Rigid3d& estimated, const Rigid3d& truth) {
  PoseError error;
  error.rotation_deg = rad2deg(rotation_angle(truth.linear().transpose() * estimated.linear()));
  error.translation_m = (estimated.translation() - truth.translation()).norm();
  return error;
}

std::vector<PoseError> extrinsics_errors(const std::vector<Rigid3d>& estimated_ref_from_cam,
                                         const std::vector<Rigid3d>& true_ref_from_cam) {
  if (estimated_ref_from_cam.size() != true_ref_from_cam.size())
    throw make_error("", "extrinsics",
                     std::to_string(estimated_ref_from_cam.size()) + " estimated cameras but " +
                         std::to_string(true_ref_from_cam.size()) + " true ones");
  std::vector<PoseError> errors;
  for (std::size_t c = 0; c < true_ref_from_cam.size(); ++c)
    errors.push_back(pose_error(estimated_ref_from_cam[c], true_ref_from_cam[c]));
  return errors;
}

Line3d axis_line(const Rigid3d& world_from_axis) {
  return {world_from_axis.translation(), world_from_axis.linear().col(2)};
}

namespace {

double point_line_distance(const Eigen::Vector3d& point, const Line3d& line, const Eigen::Vector3d& unit_direction) {
  const Eigen::Vector3d offset = point - line.point;
  return (offset - offset.dot(unit_direction) * unit_direction).norm();
}

}  // namespace

AxisError axis_error(const Line3d& estimated, const Line3d& truth) {
  if (!(estimated.direction.norm() > 0) || !(truth.direction.norm() > 0) || !estimated.point.allFinite() ||
      !truth.point.allFinite() || !estimated.direction.allFinite() || !truth.direction.allFinite())
    throw make_error("", "axis", "an axis needs a finite point and a non-zero finite direction");
  const Eigen::Vector3d d_est = estimated.direction.normalized();
  const Eigen::Vector3d d_true = truth.direction.normalized();
  const Eigen::Vector3d cross = d_est.cross(d_true);
  AxisError error;
  // atan2 of |sin| and |cos|: accurate for small angles, and sign-free because a line has none.
  error.angle_deg = rad2deg(std::atan2(cross.norm(), std::abs(d_est.dot(d_true))));
  const Eigen::Vector3d between = truth.point - estimated.point;
  if (cross.norm() < 1e-12) {
    error.line_distance_m = point_line_distance(truth.point, estimated, d_est);  // parallel lines
  } else {
    // Skew lines: the component of the offset along the common normal.
    error.line_distance_m = std::abs(between.dot(cross)) / cross.norm();
  }
  error.offset_at_reference_m = point_line_distance(truth.point, estimated, d_est);
  return error;
}

}  // namespace panoscan::eval
