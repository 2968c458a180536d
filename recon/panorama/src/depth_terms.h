// Internal to panoscan_recon_panorama (and its tests): the terms of the panorama depth energy,
//   Eq. 5:  E(D) = sum_p sum_k |D_p - z_pk| + lambda_b * sum_p S_p(D),
// one named function per term, each evaluated at one pixel (the "anchor") and its stencil of
// neighbours. The solver (depth_solver.cpp) sums them over all pixels and gathers the per-slot
// derivatives into the gradient.
//
// Every |.| is smoothed for the gradient-based solver: |x| -> sqrt(x^2 + eps^2) - eps (the
// "smoothed" value; "exact" is the unsmoothed one that the energy log reports). Besides the
// gradient each term returns a positive curvature estimate per slot (IRLS majoriser of the norms,
// Gauss-Newton for TP's squared norms), the diagonal preconditioner of L-BFGS.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "depth_lanes.h"
#include "panoscan/recon/panorama.h"

namespace panoscan::depth_terms {

// The data term of Eq. 5 at one pixel: sum_k |D - z_k| over its measurements.
struct DataTerm {
  double smoothed = 0.0, exact = 0.0;
  double gradient = 0.0;   // d smoothed / d D
  double curvature = 0.0;  // d^2 smoothed / d D^2
};

namespace detail {
inline double radial_of(const PanoramaMeasurement& m) { return double(m.radial_m); }
inline double radial_of(float radial_m) { return double(radial_m); }
}  // namespace detail

// The solver's hot loop (every measurement, every evaluation), over the measurements themselves or
// over a plain array of their radial depths (the solver's copy: a third of the memory traffic).
// The square root and the division of two measurements at a time are packed SSE2 instructions
// (correctly rounded, as the scalar ones are); the four sums still take one measurement after the
// other. So the value is the scalar loop's bit for bit, and the latency of the square root and
// division, most of the loop's time, is paid once per pair. One division (1 / s) per measurement,
// its gradient r / s and curvature eps^2 / s^3 as products of it: the divider is what bounds the
// loop (session 53: two divisions before, ~6% of the solve; the values differ by a few ulp).
// `t` holds the sums so far (data_term_pair continues a pixel's sums here).
template <typename Measurement>
DataTerm data_term(double depth, const Measurement* begin, const Measurement* end, double eps, DataTerm t = {}) {
  const double eps2 = eps * eps;
  const Measurement* m = begin;
#if defined(__SSE2__)
  const __m128d eps2_pair = _mm_set1_pd(eps2);
  for (; end - m >= 2; m += 2) {
    const double r0 = depth - detail::radial_of(m[0]), r1 = depth - detail::radial_of(m[1]);
    const __m128d r = _mm_set_pd(r1, r0);
    const __m128d s = _mm_sqrt_pd(_mm_add_pd(_mm_mul_pd(r, r), eps2_pair));
    const __m128d inverse = _mm_div_pd(_mm_set1_pd(1.0), s);
    const __m128d gradient = _mm_mul_pd(r, inverse);
    const __m128d curvature = _mm_mul_pd(_mm_mul_pd(_mm_mul_pd(eps2_pair, inverse), inverse), inverse);
    const double s0 = _mm_cvtsd_f64(s), s1 = _mm_cvtsd_f64(_mm_unpackhi_pd(s, s));
    const double g0 = _mm_cvtsd_f64(gradient), g1 = _mm_cvtsd_f64(_mm_unpackhi_pd(gradient, gradient));
    const double c0 = _mm_cvtsd_f64(curvature), c1 = _mm_cvtsd_f64(_mm_unpackhi_pd(curvature, curvature));
    t.smoothed += s0 - eps;
    t.exact += std::abs(r0);
    t.gradient += g0;
    t.curvature += c0;
    t.smoothed += s1 - eps;
    t.exact += std::abs(r1);
    t.gradient += g1;
    t.curvature += c1;
  }
#endif
  for (; m != end; ++m) {
    const double r = depth - detail::radial_of(*m);
    const double s = std::sqrt(r * r + eps2);
    t.smoothed += s - eps;
    t.exact += std::abs(r);
    const double inverse = 1.0 / s;
    t.gradient += r * inverse;
    t.curvature += eps2 * inverse * inverse * inverse;
  }
  return t;
}

// data_term of two pixels at once (the solver's loop): lane 0 of each packed instruction is pixel
// 0's measurement k, lane 1 pixel 1's, so each pixel's sums still take its measurements one after
// the other (its value is data_term's bit for bit) while the two pixels' additions, square roots
// and divisions share instructions. The longer set is finished by data_term.
inline void data_term_pair(double depth0, const float* begin0, const float* end0, double depth1, const float* begin1,
                           const float* end1, double eps, DataTerm& t0, DataTerm& t1) {
  t0 = DataTerm{};
  t1 = DataTerm{};
  std::ptrdiff_t k = 0;
#if defined(__SSE2__)
  const std::ptrdiff_t common = std::min(end0 - begin0, end1 - begin1);
  const double eps2 = eps * eps;
  const __m128d eps_pair = _mm_set1_pd(eps), eps2_pair = _mm_set1_pd(eps2), sign = _mm_set1_pd(-0.0);
  const __m128d depth = _mm_set_pd(depth1, depth0);
  __m128d smoothed = _mm_setzero_pd(), exact = _mm_setzero_pd(), gradient = _mm_setzero_pd(),
          curvature = _mm_setzero_pd();
  for (; k < common; ++k) {
    const __m128d r = _mm_sub_pd(depth, _mm_set_pd(double(begin1[k]), double(begin0[k])));
    const __m128d s = _mm_sqrt_pd(_mm_add_pd(_mm_mul_pd(r, r), eps2_pair));
    smoothed = _mm_add_pd(smoothed, _mm_sub_pd(s, eps_pair));
    exact = _mm_add_pd(exact, _mm_andnot_pd(sign, r));  // |r|
    const __m128d inverse = _mm_div_pd(_mm_set1_pd(1.0), s);
    gradient = _mm_add_pd(gradient, _mm_mul_pd(r, inverse));
    curvature = _mm_add_pd(curvature, _mm_mul_pd(_mm_mul_pd(_mm_mul_pd(eps2_pair, inverse), inverse), inverse));
  }
  const auto lo = [](__m128d v) { return _mm_cvtsd_f64(v); };
  const auto hi = [](__m128d v) { return _mm_cvtsd_f64(_mm_unpackhi_pd(v, v)); };
  t0.smoothed = lo(smoothed), t0.exact = lo(exact), t0.gradient = lo(gradient), t0.curvature = lo(curvature);
  t1.smoothed = hi(smoothed), t1.exact = hi(exact), t1.gradient = hi(gradient), t1.curvature = hi(curvature);
#endif
  t0 = data_term(depth0, begin0 + k, end0, eps, t0);
  t1 = data_term(depth1, begin1 + k, end1, eps, t1);
}

#if defined(PANOSCAN_DEPTH_TERMS_AVX)
namespace detail {
// depth_terms_avx.cpp: data_term of four pixels, lane j pixel j (its measurements
// [begin[j], end[j])); sums[k][j] is DataTerm's k-th field (smoothed, exact, gradient, curvature)
// of lane j. Compiled with -mavx: call only where the CPU has it. Every lane loads
// begin[j][0 .. longest - 1], longest the largest set: the floats past a lane's own end must be
// readable (their values, whatever they are, are masked off).
void data_term_quad_avx(const double depth[4], const float* const begin[4], const float* const end[4], double eps,
                        double sums[4][4]);
}  // namespace detail

// data_term of four pixels at once, one per lane of each AVX instruction (the solver's loop where
// the CPU has AVX): every pixel's value is data_term's bit for bit (depth_terms_avx.cpp says why).
// Reads up to the largest set's size past each begin (detail::data_term_quad_avx).
inline void data_term_quad(const double depth[4], const float* const begin[4], const float* const end[4], double eps,
                           DataTerm out[4]) {
  double sums[4][4];
  detail::data_term_quad_avx(depth, begin, end, eps, sums);
  for (int j = 0; j < 4; ++j) out[j] = DataTerm{sums[0][j], sums[1][j], sums[2][j], sums[3][j]};
}
#endif

// The stencil of a smoothness term: the anchor pixel and its four neighbours (azimuth periodic),
// each with its depth, unit ray and sin(theta) (theta the polar angle from the zenith).
enum Slot { kAnchor = 0, kLeft, kRight, kUp, kDown, kSlots };

struct Stencil {
  std::array<bool, kSlots> present{};
  std::array<double, kSlots> depth{};
  std::array<Eigen::Vector3d, kSlots> ray;
  std::array<double, kSlots> sin_theta{};

  Eigen::Vector3d point(int slot) const { return depth[slot] * ray[slot]; }
};

// A smoothness term's value and derivatives with respect to the depths of the stencil's slots
// (absent neighbours get zeros).
struct StencilTerm {
  double smoothed = 0.0, exact = 0.0;
  std::array<double, kSlots> gradient{};
  std::array<double, kSlots> curvature{};
};

// Total variation with backward differences, |(q_p - q_left, q_p - q_up)|, on the cylindrical
// radius q = D sin(theta) (`cylindrical`, the paper's TV-L1 on the cylinder) or on the radial depth
// q = D. Zero at a pixel with neither a left nor an upper neighbour.
inline StencilTerm tv_term(const Stencil& st, bool cylindrical, double eps) {
  StencilTerm t;
  const bool l = st.present[kLeft], u = st.present[kUp];
  if (!l && !u) return t;
  auto scale = [&](int slot) { return cylindrical ? st.sin_theta[slot] : 1.0; };
  const double qi = st.depth[kAnchor] * scale(kAnchor);
  const double dl = l ? qi - st.depth[kLeft] * scale(kLeft) : 0.0;
  const double du = u ? qi - st.depth[kUp] * scale(kUp) : 0.0;
  const double norm2 = dl * dl + du * du;
  const double s = std::sqrt(norm2 + eps * eps);
  t.smoothed = s - eps;
  t.exact = std::sqrt(norm2);
  t.gradient[kAnchor] = (dl + du) / s * scale(kAnchor);
  t.curvature[kAnchor] = (int(l) + int(u)) * scale(kAnchor) * scale(kAnchor) / s;
  if (l) {
    t.gradient[kLeft] = -dl / s * scale(kLeft);
    t.curvature[kLeft] = scale(kLeft) * scale(kLeft) / s;
  }
  if (u) {
    t.gradient[kUp] = -du / s * scale(kUp);
    t.curvature[kUp] = scale(kUp) * scale(kUp) / s;
  }
  return t;
}

// Eq. 6, total surface area: the area |dP_-phi x dP_-theta| of the quad spanned by the anchor's
// point and its left and upper neighbours' points. Needs both neighbours (else zero).
// tsa_term's arithmetic on the anchor p and its left (l) and upper (u) neighbours, both present
// (each given as depth and unit ray); index 0, 1, 2 of gradient and curvature = anchor, left, up.
// The solver calls it directly (no stencil assembled per pixel); tsa_term calls it too, so both
// give the same bits.
struct TsaCore {
  double smoothed = 0.0, exact = 0.0;
  double gradient[3] = {0, 0, 0};
  double curvature[3] = {0, 0, 0};
};

// The arithmetic is depth_lanes.h's, shared with the solver's four-pixel AVX version: with
// P = D_p r_p, a = P - D_l r_l, b = P - D_u r_u and c = a x b, the term is |c| (smoothed
// sqrt(|c|^2 + eps^2) - eps), its gradient (b x g + g x a) . r_p, -(b x g) . r_l, -(g x a) . r_u
// with g = c / s, and its curvature |r_p x (b - a)|^2 / s, |r_l x b|^2 / s, |r_u x a|^2 / s.
inline TsaCore tsa_core(double depth_p, const Eigen::Vector3d& ray_p, double depth_l, const Eigen::Vector3d& ray_l,
                        double depth_u, const Eigen::Vector3d& ray_u, double eps) {
  const auto vec = [](const Eigen::Vector3d& r) { return lanes::Vec3<double>{r.x(), r.y(), r.z()}; };
  double out[8];
  const auto sqrt_lanes = [](double v) { return std::sqrt(v); };
  lanes::tsa_lanes(depth_p, vec(ray_p), depth_l, vec(ray_l), depth_u, vec(ray_u), eps, sqrt_lanes, out);
  TsaCore t;
  t.smoothed = out[0];
  t.exact = out[1];
  for (int k = 0; k < 3; ++k) {
    t.gradient[k] = out[2 + k];
    t.curvature[k] = out[5 + k];
  }
  return t;
}

#if defined(PANOSCAN_DEPTH_TERMS_AVX)
namespace detail {
// depth_terms_avx.cpp: tsa_core of four anchors (lane j: depth_p[j], ray component c ray_p[c][j],
// ...), out[k][j] the k-th of depth_lanes.h's eight values for lane j. Compiled with -mavx: call
// only where the CPU has it.
void tsa_quad_avx(const double depth_p[4], const double ray_p[3][4], const double depth_l[4], const double ray_l[3][4],
                  const double depth_u[4], const double ray_u[3][4], double eps, double out[8][4]);
}  // namespace detail
#endif

inline StencilTerm tsa_term(const Stencil& st, double eps) {
  StencilTerm t;
  if (!st.present[kLeft] || !st.present[kUp]) return t;
  const TsaCore core =
      tsa_core(st.depth[kAnchor], st.ray[kAnchor], st.depth[kLeft], st.ray[kLeft], st.depth[kUp], st.ray[kUp], eps);
  t.smoothed = core.smoothed;
  t.exact = core.exact;
  const int slots[3] = {kAnchor, kLeft, kUp};
  for (int k = 0; k < 3; ++k) {
    t.gradient[slots[k]] = core.gradient[k];
    t.curvature[slots[k]] = core.curvature[k];
  }
  return t;
}

// Eq. 7, total planarity: |dP_-phi x dP_+phi|^2 + |dP_-theta x dP_+theta|^2, each pair where both
// of its neighbours exist (a squared norm: no smoothing, smoothed = exact).
inline StencilTerm tp_term(const Stencil& st) {
  StencilTerm t;
  const Eigen::Vector3d pi = st.point(kAnchor);
  auto pair_term = [&](int before, int after) {
    if (!st.present[before] || !st.present[after]) return;
    const Eigen::Vector3d a = pi - st.point(before);
    const Eigen::Vector3d b = st.point(after) - pi;
    const Eigen::Vector3d c = a.cross(b);
    t.smoothed += c.squaredNorm();
    const Eigen::Vector3d g = 2.0 * c;
    const Eigen::Vector3d grad_a = b.cross(g), grad_b = g.cross(a);
    t.gradient[kAnchor] += (grad_a - grad_b).dot(st.ray[kAnchor]);
    t.gradient[before] += -grad_a.dot(st.ray[before]);
    t.gradient[after] += grad_b.dot(st.ray[after]);
    // Gauss-Newton: 2 |dc/dD|^2, c is linear in each depth.
    t.curvature[kAnchor] += 2.0 * st.ray[kAnchor].cross(a + b).squaredNorm();
    t.curvature[before] += 2.0 * st.ray[before].cross(b).squaredNorm();
    t.curvature[after] += 2.0 * a.cross(st.ray[after]).squaredNorm();
  };
  pair_term(kLeft, kRight);
  pair_term(kUp, kDown);
  t.exact = t.smoothed;
  return t;
}

}  // namespace panoscan::depth_terms
