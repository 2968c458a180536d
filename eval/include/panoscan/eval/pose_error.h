// Errors between an estimated and a true rigid transform, and between two axes (lines): used for
// the rig's extrinsics (T_c), the rotation axis (T_u) and registration (docs/ARCHITECTURE.md §13).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "panoscan/core/geometry.h"

namespace panoscan::eval {

struct PoseError {
  double rotation_deg = 0.0;   // angle of R_true^T * R_est
  double translation_m = 0.0;  // |t_est - t_true|
};

// Both transforms map the same frames (e.g. both ref_from_cam, or both target_from_source).
PoseError pose_error(const Rigid3d& estimated, const Rigid3d& truth);

// Extrinsics of every camera (ref_from_cam); the vectors must have equal length.
std::vector<PoseError> extrinsics_errors(const std::vector<Rigid3d>& estimated_ref_from_cam,
                                         const std::vector<Rigid3d>& true_ref_from_cam);

// A line through `point` along `direction` (need not be unit; must be non-zero).
struct Line3d {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

// The rotation axis of a pose T_u given as world_from_axis: the axis frame's z axis through its
// origin.
Line3d axis_line(const Rigid3d& world_from_axis);

struct AxisError {
  double angle_deg = 0.0;              // between the lines, in [0, 90] (a line has no sign)
  double line_distance_m = 0.0;        // closest approach of the two lines
  double offset_at_reference_m = 0.0;  // distance from truth.point to the estimated line
};
// The closest approach of nearly parallel lines can lie far away; offset_at_reference_m measures
// the offset where it matters (pick truth.point at the rig's height).
AxisError axis_error(const Line3d& estimated, const Line3d& truth);

}  // namespace panoscan::eval
