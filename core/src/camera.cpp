#include "panoscan/core/camera.h"

#include <algorithm>
#include <cmath>

namespace panoscan {

PinholeIntrinsics PinholeIntrinsics::primesense(int width, int height) {
  PinholeIntrinsics k;
  k.width = width;
  k.height = height;
  // 570 px at 640 columns; keep the field of view when the resolution changes.
  k.fx = 570.0 * width / 640.0;
  k.fy = 570.0 * height / 480.0;
  k.cx = 0.5 * width - 0.5;
  k.cy = 0.5 * height - 0.5;
  return k;
}

double PinholeIntrinsics::fov_x() const { return 2.0 * std::atan(0.5 * width / fx); }
double PinholeIntrinsics::fov_y() const { return 2.0 * std::atan(0.5 * height / fy); }

Eigen::Vector3d Equirectangular::direction(double u, double v) const {
  const double phi = 2.0 * M_PI * (u + 0.5) / width();
  const double theta = M_PI * (v + 0.5) / height;
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

Eigen::Vector2d Equirectangular::pixel(const Eigen::Vector3d& direction) const {
  const Eigen::Vector3d d = direction.normalized();
  double phi = std::atan2(d.y(), d.x());
  if (phi < 0) phi += 2.0 * M_PI;
  const double theta = std::acos(std::clamp(d.z(), -1.0, 1.0));
  return {phi / (2.0 * M_PI) * width() - 0.5, theta / M_PI * height - 0.5};
}

}  // namespace panoscan
