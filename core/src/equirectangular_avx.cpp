// Equirectangular::pixels four directions per AVX instruction. This file alone is compiled with
// -mavx (core/CMakeLists.txt); camera.cpp calls it only where the CPU has AVX. It includes nothing
// that defines shared inline functions (equirectangular_lanes.h says why).
#include <immintrin.h>

#include "equirectangular_lanes.h"

namespace panoscan::detail {

void equirectangular_pixels_avx(std::size_t n, const double* x, const double* y, const double* z, double width,
                                double height, double* u, double* v) {
  lanes::pixels_of<__m256d>(n, x, y, z, width, height, u, v, [](__m256d a) { return _mm256_sqrt_pd(a); });
}

}  // namespace panoscan::detail
