// The TSA term (depth_lanes.h) four pixels per AVX instruction. This file alone is compiled with
// -mavx (recon/panorama/CMakeLists.txt); the solver calls it only where the CPU has AVX. It includes
// nothing that defines shared inline functions (depth_lanes.h says why).
#include <immintrin.h>

#include "depth_lanes.h"

namespace panoscan::depth_terms::detail {

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
