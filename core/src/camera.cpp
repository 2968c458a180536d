#include "panoscan/core/camera.h"
#include "panoscan/core/cpu_features.h"

#include <algorithm>
#include <cmath>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "equirectangular_lanes.h"

namespace panoscan {

#if defined(PANOSCAN_EQUIRECTANGULAR_AVX)
namespace detail {
// equirectangular_avx.cpp, compiled with -mavx.
void equirectangular_pixels_avx(std::size_t n, const double* x, const double* y, const double* z, double width,
                                double height, double* u, double* v);
}  // namespace detail
#endif

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

// The angles come from equirectangular_lanes.h's atan2 (within 1.5 ulp), not libm's atan2 and acos:
// the batched pixels() computes them four at a time, and the scalar pixel() must give the same
// bits. (libm's atan2 and acos were most of the panorama warping's time.) Polar angle
// atan2(rho, z) is also better conditioned near the poles than acos(z / r).
Eigen::Vector2d Equirectangular::pixel(const Eigen::Vector3d& direction) const {
  const double x = direction.x(), y = direction.y(), z = direction.z();
  double u = 0.0, v = 0.0;
  lanes::pixel_of(x, y, z, std::sqrt(x * x + y * y), double(width()), double(height), u, v);
  return {u, v};
}

void Equirectangular::pixels(std::size_t n, const double* x, const double* y, const double* z, double* u,
                             double* v) const {
  const double w = double(width()), h = double(height);
  std::size_t done = 0;
#if defined(PANOSCAN_EQUIRECTANGULAR_AVX)
  if (cpu::has_avx()) {
    done = n / 4 * 4;
    detail::equirectangular_pixels_avx(done, x, y, z, w, h, u, v);
  }
#endif
#if defined(__SSE2__)
  const std::size_t pairs_end = done + (n - done) / 2 * 2;
  lanes::pixels_of<__m128d>(pairs_end - done, x + done, y + done, z + done, w, h, u + done, v + done,
                            [](__m128d a) { return _mm_sqrt_pd(a); });
  done = pairs_end;
#endif
  for (std::size_t i = done; i < n; ++i) {
    const Eigen::Vector2d p = pixel(Eigen::Vector3d(x[i], y[i], z[i]));
    u[i] = p.x();
    v[i] = p.y();
  }
}

}  // namespace panoscan
