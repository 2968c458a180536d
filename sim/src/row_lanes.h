// The renderer's row passes written once for a lane type (private to sim/src): the geometry of a
// traced row and its Lambert lighting, a few pixels per vector operation. renderer.cpp instantiates
// them for SSE (four lanes, baseline x86-64) and renderer_avx.cpp, the one file of this library
// compiled with -mavx, for AVX (eight lanes), chosen at run time. Every lane does the float operations
// of Renderer::Impl::shade's callers for one pixel, in their order and without FMA, so the row is
// bit for bit the per-pixel reference's whichever lane type runs it.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include <Eigen/Core>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace panoscan::render_rows {

// One row between the intersection and the shading passes, structure of arrays padded to whole
// packets (a multiple of every lane width), so that the shading passes run several pixels per vector
// operation.
struct RowScratch {
  explicit RowScratch(int padded_width) {
    const std::size_t n = std::size_t(padded_width);
    for (std::vector<float>* plane :
         {&t, &u, &v, &dir_x, &dir_y, &dir_z, &normal_x, &normal_y, &normal_z, &point_x, &point_y, &point_z, &footprint,
          &incidence, &depth, &albedo_r, &albedo_g, &albedo_b, &diffuse})
      plane->resize(n);
    triangle.resize(n);
    hit.resize(n);
    rgb.resize(3 * n);
  }
  std::vector<float> t, u, v, dir_x, dir_y, dir_z;
  std::vector<unsigned> triangle;  // RTC_INVALID_GEOMETRY_ID: no hit
  std::vector<std::int32_t> hit;   // all ones for a hit, 0 for none: a lane mask
  // The triangle's normal turned towards the ray, the hit point, and the pixel's footprint.
  std::vector<float> normal_x, normal_y, normal_z, point_x, point_y, point_z, footprint, incidence, depth;
  std::vector<float> albedo_r, albedo_g, albedo_b, diffuse;
  std::vector<std::int32_t> rgb;  // three planes of the row's 8-bit colour
};

// The lights as structure of arrays (Renderer::Impl's).
struct LightArrays {
  const std::vector<float>& x;
  const std::vector<float>& y;
  const std::vector<float>& z;
  const std::vector<float>& intensity;
  std::size_t count;
};

// One lane: the reference for targets without SSE2; masks are all-ones or all-zeros bit patterns.
struct ScalarLanes {
  using V = float;
  static constexpr int kWidth = 1;
  static std::uint32_t bits(float f) {
    std::uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return b;
  }
  static float from_bits(std::uint32_t b) {
    float f;
    std::memcpy(&f, &b, sizeof f);
    return f;
  }
  static V load(const float* p) { return *p; }
  static V load_mask(const std::int32_t* p) { return from_bits(std::uint32_t(*p)); }
  static void store(float* p, V v) { *p = v; }
  static V set1(float f) { return f; }
  static V zero() { return 0.f; }
  static V add(V a, V b) { return a + b; }
  static V sub(V a, V b) { return a - b; }
  static V mul(V a, V b) { return a * b; }
  static V div(V a, V b) { return a / b; }
  static V sqrt(V a) { return std::sqrt(a); }
  static V max(V a, V b) { return b < a ? a : b; }  // maxps: the second operand unless a > b
  static V min(V a, V b) { return a < b ? a : b; }  // minps: the second operand unless a < b
  static V bit_and(V a, V b) { return from_bits(bits(a) & bits(b)); }
  static V and_not(V a, V b) { return from_bits(~bits(a) & bits(b)); }
  static V bit_xor(V a, V b) { return from_bits(bits(a) ^ bits(b)); }
  static V greater(V a, V b) { return from_bits(a > b ? 0xFFFFFFFFu : 0u); }
};

#if defined(__SSE2__)
struct SseLanes {
  using V = __m128;
  static constexpr int kWidth = 4;
  static V load(const float* p) { return _mm_loadu_ps(p); }
  static V load_mask(const std::int32_t* p) {
    return _mm_castsi128_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  }
  static void store(float* p, V v) { _mm_storeu_ps(p, v); }
  static V set1(float f) { return _mm_set1_ps(f); }
  static V zero() { return _mm_setzero_ps(); }
  static V add(V a, V b) { return _mm_add_ps(a, b); }
  static V sub(V a, V b) { return _mm_sub_ps(a, b); }
  static V mul(V a, V b) { return _mm_mul_ps(a, b); }
  static V div(V a, V b) { return _mm_div_ps(a, b); }
  static V sqrt(V a) { return _mm_sqrt_ps(a); }
  static V max(V a, V b) { return _mm_max_ps(a, b); }
  static V min(V a, V b) { return _mm_min_ps(a, b); }
  static V bit_and(V a, V b) { return _mm_and_ps(a, b); }
  static V and_not(V a, V b) { return _mm_andnot_ps(a, b); }  // ~a & b
  static V bit_xor(V a, V b) { return _mm_xor_ps(a, b); }
  static V greater(V a, V b) { return _mm_cmpgt_ps(a, b); }
};
#endif

#if defined(__AVX__)
struct AvxLanes {
  using V = __m256;
  static constexpr int kWidth = 8;
  static V load(const float* p) { return _mm256_loadu_ps(p); }
  static V load_mask(const std::int32_t* p) {
    return _mm256_castsi256_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)));
  }
  static void store(float* p, V v) { _mm256_storeu_ps(p, v); }
  static V set1(float f) { return _mm256_set1_ps(f); }
  static V zero() { return _mm256_setzero_ps(); }
  static V add(V a, V b) { return _mm256_add_ps(a, b); }
  static V sub(V a, V b) { return _mm256_sub_ps(a, b); }
  static V mul(V a, V b) { return _mm256_mul_ps(a, b); }
  static V div(V a, V b) { return _mm256_div_ps(a, b); }
  static V sqrt(V a) { return _mm256_sqrt_ps(a); }
  static V max(V a, V b) { return _mm256_max_ps(a, b); }
  static V min(V a, V b) { return _mm256_min_ps(a, b); }
  static V bit_and(V a, V b) { return _mm256_and_ps(a, b); }
  static V and_not(V a, V b) { return _mm256_andnot_ps(a, b); }  // ~a & b
  static V bit_xor(V a, V b) { return _mm256_xor_ps(a, b); }
  static V greater(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
};
#endif

// Per pixel: incidence |n.d| / |d|, footprint, hit point and the normal turned towards the ray; the
// depth and incidence 0 where nothing was hit. |d| and n.d are summed x + (y + z), as Eigen's norm()
// and dot() sum them. A pixel covers range / f metres across the ray, stretched by 1 / cos along the
// slope; the geometric mean of the two keeps slanted floors sharp without aliasing.
template <typename L>
void row_geometry_lanes(RowScratch& row, int padded_width, const Eigen::Vector3f& origin, float inv_fx) {
  using V = typename L::V;
  const V sign_bit = L::set1(-0.f);
  const V origin_x = L::set1(origin.x()), origin_y = L::set1(origin.y()), origin_z = L::set1(origin.z());
  for (int x = 0; x < padded_width; x += L::kWidth) {
    const V t = L::load(&row.t[x]);
    const V dx = L::load(&row.dir_x[x]), dy = L::load(&row.dir_y[x]), dz = L::load(&row.dir_z[x]);
    const V nx = L::load(&row.normal_x[x]), ny = L::load(&row.normal_y[x]), nz = L::load(&row.normal_z[x]);
    const V hit = L::load_mask(&row.hit[x]);
    const V length = L::sqrt(L::add(L::mul(dx, dx), L::add(L::mul(dy, dy), L::mul(dz, dz))));
    const V dot = L::add(L::mul(nx, dx), L::add(L::mul(ny, dy), L::mul(nz, dz)));
    const V incidence = L::div(L::and_not(sign_bit, dot), length);
    const V footprint = L::div(L::mul(L::mul(t, length), L::set1(inv_fx)), L::sqrt(L::max(incidence, L::set1(0.05f))));
    const V flip = L::bit_and(L::greater(dot, L::zero()), sign_bit);
    L::store(&row.normal_x[x], L::bit_xor(nx, flip));
    L::store(&row.normal_y[x], L::bit_xor(ny, flip));
    L::store(&row.normal_z[x], L::bit_xor(nz, flip));
    L::store(&row.point_x[x], L::add(origin_x, L::mul(t, dx)));
    L::store(&row.point_y[x], L::add(origin_y, L::mul(t, dy)));
    L::store(&row.point_z[x], L::add(origin_z, L::mul(t, dz)));
    L::store(&row.footprint[x], footprint);
    L::store(&row.incidence[x], L::bit_and(incidence, hit));
    L::store(&row.depth[x], L::bit_and(t, hit));
  }
}

// Lambert from the point lights: per lane the float operations of Renderer::Impl::shade's light
// loop, lights summed in the same order; a light behind the surface adds +0.
template <typename L>
void row_diffuse_lanes(RowScratch& row, int padded_width, const LightArrays& lights) {
  using V = typename L::V;
  const V light_count = L::set1(float(lights.count));
  for (int x = 0; x < padded_width; x += L::kWidth) {
    const V px = L::load(&row.point_x[x]), py = L::load(&row.point_y[x]), pz = L::load(&row.point_z[x]);
    const V nx = L::load(&row.normal_x[x]), ny = L::load(&row.normal_y[x]), nz = L::load(&row.normal_z[x]);
    V diffuse = L::zero();
    for (std::size_t l = 0; l < lights.count; ++l) {
      const V tx = L::sub(L::set1(lights.x[l]), px);
      const V ty = L::sub(L::set1(lights.y[l]), py);
      const V tz = L::sub(L::set1(lights.z[l]), pz);
      const V facing = L::add(L::mul(nx, tx), L::add(L::mul(ny, ty), L::mul(nz, tz)));
      const V d2 = L::max(L::add(L::mul(tx, tx), L::add(L::mul(ty, ty), L::mul(tz, tz))), L::set1(1e-8f));
      const V numerator = L::mul(L::mul(L::set1(lights.intensity[l]), facing), L::set1(2.f));
      const V denominator = L::mul(L::sqrt(d2), L::add(L::set1(1.f), L::mul(L::set1(0.25f), d2)));
      diffuse = L::add(diffuse, L::bit_and(L::div(numerator, denominator), L::greater(facing, L::zero())));
    }
    L::store(&row.diffuse[x], L::min(L::div(diffuse, light_count), L::set1(1.2f)));
  }
}

// Defined in renderer_avx.cpp (compiled with -mavx) where the build has it; callers check the CPU.
void row_geometry_avx(RowScratch& row, int padded_width, const Eigen::Vector3f& origin, float inv_fx);
void row_diffuse_avx(RowScratch& row, int padded_width, const LightArrays& lights);

}  // namespace panoscan::render_rows
