// Private to panoscan_core: Equirectangular::pixel's arithmetic, written once for a lane type V that
// is a double or a GCC vector of doubles (__m128d, __m256d), so that the scalar pixel() and the
// batched pixels() are the same operations lane for lane and agree bit for bit.
//
// Deliberately in an anonymous namespace: camera.cpp (baseline x86-64, SSE2) and
// equirectangular_avx.cpp (compiled with -mavx) each get their own copy compiled for their own
// instruction set; shared inline definitions would let the linker pick the AVX copy for everyone.
// For the same reason nothing here calls the standard library.
#pragma once

#include <cstddef>

namespace panoscan {
namespace {

namespace lanes {

template <typename V>
inline V splat(double c) {
  return V{} + c;
}

// atan(s) / s - 1 = s^2 P(s^2) on |s| <= tan(pi/8): the degree-10 Chebyshev fit of mpmath.chebyfit
// (50 digits); its error relative to atan(s) is below 6e-18, well under the 1.1e-16 of a double.
constexpr double kAtanPoly[11] = {-0.01917688711906226, 0.03923165829558719, -0.0508544973794026,  0.0585814891280221,
                                  -0.06664511447381948, 0.07692183190826087, -0.09090904578123903, 0.11111111015256361,
                                  -0.14285714284666542, 0.1999999999999552,  -0.3333333333333333};
constexpr double kTanPi8 = 0.41421356237309503;  // tan(pi/8)
constexpr double kPi = 3.141592653589793;

// atan2(y, x) for y >= 0, in [0, pi]. Reduced to t = min(|x|, |y|) / max(|x|, |y|) in [0, 1], and
// above tan(pi/8) further to (t - 1) / (t + 1) with atan(t) = pi/4 + atan((t - 1) / (t + 1)), then
// the polynomial. Within 1.5 ulp of the exact value over random directions (libm's atan2: 0.52);
// the branches are selects, so the lanes of a vector need not agree. x = y = 0 gives 0 (+0) or pi
// (-0 is not negative here, unlike libm's atan2(0, -0) = pi: it gives 0).
template <typename V>
inline V atan2_upper(V y, V x) {
  const V zero = splat<V>(0.0);
  const V ax = x < zero ? -x : x;
  const auto y_larger = y > ax;
  const V low = y_larger ? ax : y, high = y_larger ? y : ax;
  const auto above_pi8 = low > splat<V>(kTanPi8) * high;
  const V numerator = above_pi8 ? low - high : low;
  V denominator = above_pi8 ? low + high : high;
  denominator = denominator == zero ? splat<V>(1.0) : denominator;
  const V s = numerator / denominator;
  const V s2 = s * s;
  V p = splat<V>(kAtanPoly[0]);
  for (int k = 1; k < 11; ++k) p = p * s2 + splat<V>(kAtanPoly[k]);
  V angle = s + s * (s2 * p);
  angle = above_pi8 ? splat<V>(0.25 * kPi) + angle : angle;
  angle = y_larger ? splat<V>(0.5 * kPi) - angle : angle;
  return x < zero ? splat<V>(kPi) - angle : angle;
}

// The continuous panorama pixel (u, v) of the direction (x, y, z) (need not be unit, must be
// non-zero), given rho = sqrt(x^2 + y^2): azimuth phi = atan2(y, x) in [0, 2 pi) (a negative
// angle -a as 2 pi - a), polar angle theta = atan2(rho, z) from +z, u = phi / (2 pi) W - 1/2,
// v = theta / pi H - 1/2.
template <typename V>
inline void pixel_of(V x, V y, V z, V rho, double width, double height, V& u, V& v) {
  const V zero = splat<V>(0.0);
  const V azimuth_upper = atan2_upper(y < zero ? -y : y, x);
  const V phi = y < zero ? splat<V>(2.0 * kPi) - azimuth_upper : azimuth_upper;
  const V theta = atan2_upper(rho, z);
  u = phi / splat<V>(2.0 * kPi) * splat<V>(width) - splat<V>(0.5);
  v = theta / splat<V>(kPi) * splat<V>(height) - splat<V>(0.5);
}

// pixel_of over n directions, L = sizeof(V) / sizeof(double) at a time (n a multiple of L);
// sqrt_lanes computes rho.
template <typename V, typename Sqrt>
inline void pixels_of(std::size_t n, const double* x, const double* y, const double* z, double width, double height,
                      double* u, double* v, const Sqrt& sqrt_lanes) {
  for (std::size_t i = 0; i < n; i += sizeof(V) / sizeof(double)) {
    V xs, ys, zs, us, vs;
    __builtin_memcpy(&xs, x + i, sizeof(V));
    __builtin_memcpy(&ys, y + i, sizeof(V));
    __builtin_memcpy(&zs, z + i, sizeof(V));
    pixel_of(xs, ys, zs, sqrt_lanes(xs * xs + ys * ys), width, height, us, vs);
    __builtin_memcpy(u + i, &us, sizeof(V));
    __builtin_memcpy(v + i, &vs, sizeof(V));
  }
}

}  // namespace lanes

}  // namespace
}  // namespace panoscan
