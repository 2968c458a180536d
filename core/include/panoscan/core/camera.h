// Camera models.
//
// Pinhole: pixel centres at integer coordinates (OpenCV convention); pixel (u, v) sees the ray
// ((u - cx) / fx, (v - cy) / fy, 1) in the camera frame (x right, y down, z forward).
// Equirectangular: an H x 2H image around a centre. Its frame has z up (the rotation axis);
// column u maps to azimuth phi = 2*pi*(u + 0.5)/W measured from +x towards +y, row v maps to
// polar angle theta = pi*(v + 0.5)/H from +z (row 0 looks up).
#pragma once

#include <cstddef>

#include <Eigen/Core>

namespace panoscan {

struct PinholeIntrinsics {
  int width = 640;
  int height = 480;
  double fx = 570.0;
  double fy = 570.0;
  double cx = 319.5;
  double cy = 239.5;

  // PrimeSense-like colour/depth camera (fx = fy = 570 at 640x480), scaled to another size.
  static PinholeIntrinsics primesense(int width, int height);

  Eigen::Vector2d project(const Eigen::Vector3d& point_in_cam) const {
    return {fx * point_in_cam.x() / point_in_cam.z() + cx, fy * point_in_cam.y() / point_in_cam.z() + cy};
  }
  // Point at depth z (along the optical axis) seen at pixel (u, v).
  Eigen::Vector3d backproject(double u, double v, double z) const { return {(u - cx) / fx * z, (v - cy) / fy * z, z}; }
  bool contains(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= -0.5 && pixel.y() >= -0.5 && pixel.x() < width - 0.5 && pixel.y() < height - 0.5;
  }
  // Horizontal / vertical field of view in radians.
  double fov_x() const;
  double fov_y() const;
};

struct Equirectangular {
  int height = 1024;  // width is 2 * height

  int width() const { return 2 * height; }
  // Unit direction of pixel (u, v) (continuous coordinates, centres at integers).
  Eigen::Vector3d direction(double u, double v) const;
  // Continuous pixel coordinates of a direction (need not be normalised, must be non-zero).
  Eigen::Vector2d pixel(const Eigen::Vector3d& direction) const;
  // pixel() of n directions given as coordinate arrays, into u[i], v[i]: the same bits as pixel()
  // one by one, several directions per SIMD instruction where the CPU has them.
  void pixels(std::size_t n, const double* x, const double* y, const double* z, double* u, double* v) const;
};

}  // namespace panoscan
