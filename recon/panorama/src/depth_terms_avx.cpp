// The solver's data term and TSA term (depth_lanes.h) four pixels per AVX instruction. This file
// alone is compiled with -mavx (recon/panorama/CMakeLists.txt); the solver calls it only where the
// CPU has AVX. It includes nothing that defines shared inline functions (depth_lanes.h says why).
#include <immintrin.h>

#include "depth_lanes.h"

namespace panoscan::depth_terms::detail {

// The data term of four pixels, one per lane (a double division or square root costs the same time
// on four lanes as on two on the CPUs measured, and they are most of the solver's loop). Each lane
// takes its pixel's measurements in order and runs to the longest set; a lane past its own set adds
// +0.0, which leaves its sums unchanged (x + 0.0 == x for every x but -0.0, and a sum that starts at
// +0.0 never becomes -0.0 in round-to-nearest). So every pixel's value is data_term's
// (depth_terms.h) bit for bit. Not FMA: the products are rounded as data_term rounds them.
void data_term_quad_avx(const double depth[4], const float* const begin[4], const float* const end[4], double eps,
                        double sums[4][4]) {
  using Index = decltype(end[0] - begin[0]);
  Index count[4], longest = 0;
  for (int j = 0; j < 4; ++j) {
    count[j] = end[j] - begin[j];
    if (count[j] > longest) longest = count[j];
  }
  const double eps2 = eps * eps;
  const __m256d eps_v = _mm256_set1_pd(eps), eps2_v = _mm256_set1_pd(eps2), sign = _mm256_set1_pd(-0.0),
                one = _mm256_set1_pd(1.0);
  const __m256d depth_v = _mm256_loadu_pd(depth);
  __m256d smoothed = _mm256_setzero_pd(), exact = _mm256_setzero_pd(), gradient = _mm256_setzero_pd(),
          curvature = _mm256_setzero_pd();
  const __m256d count_v = _mm256_set_pd(double(count[3]), double(count[2]), double(count[1]), double(count[0]));
  // The lanes are assembled in registers: four scalar stores read back as one vector would stall
  // (no store-to-load forwarding), which made this loop slower than the SSE2 pairs. A lane past its
  // set still loads (the caller keeps those floats readable) and is masked off: the test per lane
  // and step that chose 0 instead was mispredicted where each lane's set ended.
  for (Index k = 0; k < longest; ++k) {
    const __m256d mask = _mm256_cmp_pd(_mm256_set1_pd(double(k)), count_v, _CMP_LT_OQ);
    const __m256d z = _mm256_cvtps_pd(_mm_set_ps(begin[3][k], begin[2][k], begin[1][k], begin[0][k]));
    const __m256d r = _mm256_sub_pd(depth_v, z);
    const __m256d s = _mm256_sqrt_pd(_mm256_add_pd(_mm256_mul_pd(r, r), eps2_v));
    smoothed = _mm256_add_pd(smoothed, _mm256_and_pd(mask, _mm256_sub_pd(s, eps_v)));
    exact = _mm256_add_pd(exact, _mm256_and_pd(mask, _mm256_andnot_pd(sign, r)));  // |r|
    const __m256d inverse = _mm256_div_pd(one, s);
    gradient = _mm256_add_pd(gradient, _mm256_and_pd(mask, _mm256_mul_pd(r, inverse)));
    curvature = _mm256_add_pd(
        curvature, _mm256_and_pd(mask, _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(eps2_v, inverse), inverse), inverse)));
  }
  _mm256_storeu_pd(sums[0], smoothed);
  _mm256_storeu_pd(sums[1], exact);
  _mm256_storeu_pd(sums[2], gradient);
  _mm256_storeu_pd(sums[3], curvature);
}

// Lane j: anchor depth_p[j] along the ray with components ray_p[0..2][j], left and upper
// neighbours likewise. out[k][j]: value k (depth_lanes.h tsa_lanes order) of lane j.
void tsa_quad_avx(const double depth_p[4], const double ray_p[3][4], const double depth_l[4], const double ray_l[3][4],
                  const double depth_u[4], const double ray_u[3][4], double eps, double out[8][4]) {
  typedef double V __attribute__((vector_size(32)));  // __m256d without its may_alias attribute
  const auto load = [](const double values[4]) { return V(_mm256_loadu_pd(values)); };
  const auto rays = [&](const double ray[3][4]) { return lanes::Vec3<V>{load(ray[0]), load(ray[1]), load(ray[2])}; };
  V result[8];
  lanes::tsa_lanes(
      load(depth_p), rays(ray_p), load(depth_l), rays(ray_l), load(depth_u), rays(ray_u), V(_mm256_set1_pd(eps)),
      [](V v) { return V(_mm256_sqrt_pd(v)); }, result);
  for (int k = 0; k < 8; ++k) _mm256_storeu_pd(out[k], result[k]);
}

}  // namespace panoscan::depth_terms::detail
