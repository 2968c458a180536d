// The TSA term (depth_lanes.h) four pixels per AVX instruction. This file alone is compiled with
// -mavx (recon/panorama/CMakeLists.txt); the solver calls it only where the CPU has AVX. It includes
// nothing that defines shared inline functions (depth_lanes.h says why).
#include <immintrin.h>

#include "depth_lanes.h"

namespace panoscan::depth_terms::detail {

// Lane j: anchor depth_p[j] along ray_p[j] (three doubles), left and upper neighbours likewise.
// out[k][j]: TsaCore's value k (depth_lanes.h tsa_lanes order) of lane j.
void tsa_quad_avx(const double depth_p[4], const double* const ray_p[4], const double depth_l[4],
                  const double* const ray_l[4], const double depth_u[4], const double* const ray_u[4], double eps,
                  double out[8][4]) {
  typedef double V __attribute__((vector_size(32)));  // __m256d without its may_alias attribute
  const auto load = [](const double values[4]) { return _mm256_loadu_pd(values); };
  const auto rays = [](const double* const ray[4]) {
    return lanes::Vec3<V>{_mm256_set_pd(ray[3][0], ray[2][0], ray[1][0], ray[0][0]),
                          _mm256_set_pd(ray[3][1], ray[2][1], ray[1][1], ray[0][1]),
                          _mm256_set_pd(ray[3][2], ray[2][2], ray[1][2], ray[0][2])};
  };
  V result[8];
  lanes::tsa_lanes(
      load(depth_p), rays(ray_p), load(depth_l), rays(ray_l), load(depth_u), rays(ray_u), _mm256_set1_pd(eps),
      [](V v) { return _mm256_sqrt_pd(v); }, result);
  for (int k = 0; k < 8; ++k) _mm256_storeu_pd(out[k], result[k]);
}

}  // namespace panoscan::depth_terms::detail
