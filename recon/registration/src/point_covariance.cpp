#include "panoscan/recon/point_covariance.h"

#include <cmath>

namespace panoscan {

Eigen::Matrix3d equirectangular_point_covariance(double phi, double theta, double radial_depth, double sigma_angle,
                                                 double sigma_depth) {
  // p = z (sin t cos f, sin t sin f, cos t); J = [dp/df, dp/dt, dp/dz] (Eq. 9).
  const double sf = std::sin(phi), cf = std::cos(phi), st = std::sin(theta), ct = std::cos(theta);
  Eigen::Matrix3d jacobian;
  jacobian.col(0) = radial_depth * Eigen::Vector3d(-st * sf, st * cf, 0.0);
  jacobian.col(1) = radial_depth * Eigen::Vector3d(ct * cf, ct * sf, -st);
  jacobian.col(2) = Eigen::Vector3d(st * cf, st * sf, ct);
  const Eigen::Vector3d variances(sigma_angle * sigma_angle, sigma_angle * sigma_angle, sigma_depth * sigma_depth);
  return jacobian * variances.asDiagonal() * jacobian.transpose();
}

}  // namespace panoscan
