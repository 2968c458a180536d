// Measurement covariance of a point seen by an equirectangular panorama (paper Eq. 9):
// the point is p = z * d(phi, theta), so with J = [dp/dphi, dp/dtheta, dp/dz] its covariance is
// J diag(sigma_phi^2, sigma_theta^2, sigma_z^2) J^T, where sigma_phi = sigma_theta = 0.5 pi / H
// (half a pixel) and sigma_z is the per-pixel depth std (measured, or a noise model's).
#pragma once

#include <Eigen/Core>

namespace panoscan {

// `phi`: azimuth, `theta`: polar angle from +z (the Equirectangular convention of camera.h);
// the result is in the panorama's frame.
Eigen::Matrix3d equirectangular_point_covariance(double phi, double theta, double radial_depth, double sigma_angle,
                                                 double sigma_depth);

}  // namespace panoscan
