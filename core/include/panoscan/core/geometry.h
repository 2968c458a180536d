// Rigid transforms and small geometric helpers.
//
// Naming: a transform called `b_from_a` maps points in frame a to frame b
// (point_in_b = b_from_a * point_in_a). Camera frames follow OpenCV/TUM: x right, y down,
// z forward. The scene ("world") frame has z up.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <vector>

namespace panoscan {

using Rigid3d = Eigen::Isometry3d;

Rigid3d make_rigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
Rigid3d make_rigid(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);

// Rotation about a unit axis by angle (right-handed), as a rigid transform with no translation.
Rigid3d rotation_about(const Eigen::Vector3d& axis, double angle_rad);

// SO(3) exponential and logarithm (axis-angle vector <-> rotation matrix).
Eigen::Matrix3d so3_exp(const Eigen::Vector3d& rotation_vector);
Eigen::Vector3d so3_log(const Eigen::Matrix3d& rotation);

// Angle of a rotation matrix in radians, in [0, pi].
double rotation_angle(const Eigen::Matrix3d& rotation);

// Wraps an angle to [0, 2*pi).
double wrap_two_pi(double angle_rad);
// Wraps an angle to (-pi, pi].
double wrap_pi(double angle_rad);

inline double deg2rad(double deg) { return deg * 0.017453292519943295; }
inline double rad2deg(double rad) { return rad * 57.29577951308232; }

// The rotation R maximising trace(R^T m) (orthogonal Procrustes; Umeyama 1991, Eqs. 39-40: the
// SVD's reflection case handled). For m = sum (a_i - mean a)(b_i - mean b)^T it is the rotation
// of the least-squares fit a ~ R b; for m = sum A_i B_i^T of rotations, the chordal mean of A_i B_i^T.
// Sets *rank_deficient (when given) if m's second singular value is zero: then R is not unique.
Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& m, bool* rank_deficient = nullptr);

// Least-squares rigid transform (no scale) with to ~ result * from (Umeyama 1991 with c = 1).
// Needs at least 3 non-collinear pairs; returns false if the pairs are degenerate (then
// `to_from_from` is left unchanged). The one rigid fit of points in PanoScan.
bool fit_rigid_transform(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                         Rigid3d& to_from_from);

// The rigid transform T best aligning whole poses, to_i ~ T * from_i: the rotation is the chordal
// mean of R_to_i R_from_i^T (closest_rotation), the translation maps the centroid of the `from`
// positions onto that of the `to` positions. Uses orientations as well as positions, so it is
// defined for a pure in-place rotation, where the positions alone (fit_rigid_transform) are
// nearly degenerate. Identity for empty input; throws nothing.
Rigid3d fit_rigid_transform_of_poses(const std::vector<Rigid3d>& from, const std::vector<Rigid3d>& to);

// Exact Euclidean distance from a point to a triangle (closest point on the triangle,
// including its edges and vertices). Degenerate triangles fall back to the closest segment.
double point_triangle_distance(const Eigen::Vector3d& point, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c, Eigen::Vector3d* closest = nullptr);

}  // namespace panoscan
