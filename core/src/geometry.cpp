#include "panoscan/core/geometry.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>

namespace panoscan {

Rigid3d make_rigid(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  Rigid3d result = Rigid3d::Identity();
  result.linear() = rotation;
  result.translation() = translation;
  return result;
}

Rigid3d make_rigid(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation) {
  return make_rigid(rotation.normalized().toRotationMatrix(), translation);
}

Rigid3d rotation_about(const Eigen::Vector3d& axis, double angle_rad) {
  return make_rigid(Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix(), Eigen::Vector3d::Zero());
}

Eigen::Matrix3d so3_exp(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-12) {
    // First order: I + [w]x, re-orthonormalised through the quaternion.
    Eigen::Quaterniond q(1.0, 0.5 * rotation_vector.x(), 0.5 * rotation_vector.y(), 0.5 * rotation_vector.z());
    return q.normalized().toRotationMatrix();
  }
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

Eigen::Vector3d so3_log(const Eigen::Matrix3d& rotation) {
  // Through the quaternion: numerically stable near 0 and near pi.
  Eigen::Quaterniond q(rotation);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  const Eigen::Vector3d v = q.vec();
  const double sin_half = v.norm();
  if (sin_half < 1e-12) return 2.0 * v;
  const double angle = 2.0 * std::atan2(sin_half, q.w());
  return v * (angle / sin_half);
}

double rotation_angle(const Eigen::Matrix3d& rotation) { return so3_log(rotation).norm(); }

double wrap_two_pi(double angle_rad) {
  constexpr double kTwoPi = 2.0 * M_PI;
  double wrapped = std::fmod(angle_rad, kTwoPi);
  if (wrapped < 0) wrapped += kTwoPi;
  if (wrapped >= kTwoPi) wrapped = 0.0;
  return wrapped;
}

double wrap_pi(double angle_rad) {
  double wrapped = wrap_two_pi(angle_rad);
  if (wrapped > M_PI) wrapped -= 2.0 * M_PI;
  return wrapped;
}

Eigen::Matrix3d closest_rotation(const Eigen::Matrix3d& m, bool* rank_deficient) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  if (rank_deficient) *rank_deficient = svd.singularValues()[1] <= 1e-12 * std::max(1.0, svd.singularValues()[0]);
  Eigen::Matrix3d sign = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) sign(2, 2) = -1.0;
  return svd.matrixU() * sign * svd.matrixV().transpose();
}

Rigid3d fit_rigid_transform_of_poses(const std::vector<Rigid3d>& from, const std::vector<Rigid3d>& to) {
  const std::size_t n = std::min(from.size(), to.size());
  if (n == 0) return Rigid3d::Identity();
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d from_centroid = Eigen::Vector3d::Zero(), to_centroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    sum += to[i].linear() * from[i].linear().transpose();
    from_centroid += from[i].translation();
    to_centroid += to[i].translation();
  }
  const Eigen::Matrix3d rotation = closest_rotation(sum);
  return make_rigid(rotation, (to_centroid - rotation * from_centroid) / double(n));
}

bool fit_rigid_transform(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to,
                         Rigid3d& to_from_from) {
  const std::size_t n = from.size();
  if (n < 3 || to.size() != n) return false;
  Eigen::Vector3d mean_from = Eigen::Vector3d::Zero(), mean_to = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    mean_from += from[i];
    mean_to += to[i];
  }
  mean_from /= double(n);
  mean_to /= double(n);
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) cross += (to[i] - mean_to) * (from[i] - mean_from).transpose();
  // Rank < 2 (collinear or coincident points) leaves a rotation about their line free.
  bool rank_deficient = false;
  const Eigen::Matrix3d rotation = closest_rotation(cross, &rank_deficient);
  if (rank_deficient) return false;
  to_from_from = make_rigid(rotation, mean_to - rotation * mean_from);
  return true;
}

namespace {

Eigen::Vector3d closest_on_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 <= 0.0) return a;
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return a + t * ab;
}

}  // namespace

double point_triangle_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                               const Eigen::Vector3d& c, Eigen::Vector3d* closest) {
  // Region classification by barycentric tests (Ericson, Real-Time Collision Detection, 5.1.5).
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  Eigen::Vector3d result;
  if (ab.cross(ac).squaredNorm() <= 1e-30) {
    // Degenerate: the closest of the three edges.
    const Eigen::Vector3d candidates[3] = {closest_on_segment(p, a, b), closest_on_segment(p, b, c),
                                           closest_on_segment(p, c, a)};
    result = candidates[0];
    for (const auto& q : candidates)
      if ((q - p).squaredNorm() < (result - p).squaredNorm()) result = q;
  } else {
    const double d1 = ab.dot(ap), d2 = ac.dot(ap);
    const Eigen::Vector3d bp = p - b;
    const double d3 = ab.dot(bp), d4 = ac.dot(bp);
    const Eigen::Vector3d cp = p - c;
    const double d5 = ab.dot(cp), d6 = ac.dot(cp);
    const double vc = d1 * d4 - d3 * d2;
    const double vb = d5 * d2 - d1 * d6;
    const double va = d3 * d6 - d5 * d4;
    if (d1 <= 0 && d2 <= 0) {
      result = a;
    } else if (d3 >= 0 && d4 <= d3) {
      result = b;
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      result = a + (d1 / (d1 - d3)) * ab;
    } else if (d6 >= 0 && d5 <= d6) {
      result = c;
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      result = a + (d2 / (d2 - d6)) * ac;
    } else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
      result = b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
    } else {
      const double denom = 1.0 / (va + vb + vc);
      result = a + ab * (vb * denom) + ac * (vc * denom);
    }
  }
  if (closest) *closest = result;
  return (p - result).norm();
}

}  // namespace panoscan
