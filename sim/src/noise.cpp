#include "panoscan/sim/noise.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "panoscan/core/geometry.h"
#include "panoscan/core/random.h"
#include "panoscan/core/cpu_features.h"

namespace panoscan {

namespace {

// 35130 / Z_cm = 351.3 / Z_m.
constexpr double kDisparityTimesMetres = kHandaDisparityConstant / 100.0;

// kDisparityTimesMetres / q for the whole disparities q the sensor's range produces (351 / 0.5 m
// = 703; 4096 leaves room for any range): the same quotients as the division, computed once,
// because the per-pixel division was the slowest step of the noise model.
constexpr int kDepthTableSize = 4096;
const std::vector<double>& depth_of_disparity_table() {
  static const std::vector<double> table = [] {
    std::vector<double> t(kDepthTableSize, 0.0);
    for (int q = 1; q < kDepthTableSize; ++q) t[q] = kDisparityTimesMetres / double(q);
    return t;
  }();
  return table;
}

// Steps 1-3 of the Handa model (no lateral term) for the pixels [0, end) of row y, four per AVX2
// operation; returns the first pixel it did not do (a multiple of 4), the rest being the scalar
// loop's. Each lane computes exactly the scalar loop's double operations in its order (AVX2 without
// FMA rounds each lane as the scalar instruction does; min / max are std::clamp's values for the
// finite values here; the depth of a disparity is the table's quotient, divided afresh), so the
// noise is bit for bit the same.
// Only compiled for x86-64, and only called where the CPU has AVX2 (checked once at run time).
#if defined(__x86_64__) && defined(__GNUC__)
#define PANOSCAN_NOISE_AVX2 1
struct RowModel {
  const float* clean_row;
  const float* incidence_row;
  const float* inverse_depth;  // the whole image
  const std::uint8_t* speckle_hole;
  const double* shift;  // per pixel x then y
  const double* disparity_noise;
  const double* speckle_noise;
  float* noisy_row;
  int width, height, y;
  double min_cos, min_depth, max_depth;
};

__attribute__((target("avx2"))) int handa_row_avx2(const RowModel& m) {
  const int end = m.width / 4 * 4;
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0), half = _mm256_set1_pd(0.5);
  const __m256d last_column = _mm256_set1_pd(double(m.width - 1)), last_row = _mm256_set1_pd(double(m.height - 1));
  const __m256d min_cos = _mm256_set1_pd(m.min_cos), min_depth = _mm256_set1_pd(m.min_depth),
                max_depth = _mm256_set1_pd(m.max_depth);
  const __m256d disparity_times_metres = _mm256_set1_pd(kDisparityTimesMetres);
  const __m128i width_minus_1 = _mm_set1_epi32(m.width - 1), height_minus_1 = _mm_set1_epi32(m.height - 1);
  const __m128i width_i = _mm_set1_epi32(m.width), one_i = _mm_set1_epi32(1);
  const __m256d row_y = _mm256_set1_pd(double(m.y));
  for (int x = 0; x < end; x += 4) {
    const __m256d z_clean = _mm256_cvtps_pd(_mm_loadu_ps(m.clean_row + x));
    const __m256d cos_incidence = _mm256_cvtps_pd(_mm_loadu_ps(m.incidence_row + x));
    std::int32_t holes;
    std::memcpy(&holes, m.speckle_hole + x, sizeof holes);
    // Lane k of the hole mask: byte k of `holes` non-zero.
    const __m128i hole_bytes = _mm_cvtepu8_epi32(_mm_cvtsi32_si128(holes));
    const __m256d no_hole =
        _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm_cmpeq_epi32(hole_bytes, _mm_setzero_si128())));
    // !(z <= 0) && !(cos < min_cos) && no hole, as the scalar test's negation.
    __m256d valid = _mm256_and_pd(
        _mm256_and_pd(_mm256_cmp_pd(z_clean, zero, _CMP_NLE_UQ), _mm256_cmp_pd(cos_incidence, min_cos, _CMP_NLT_UQ)),
        no_hole);
    if (_mm256_movemask_pd(valid) == 0) continue;

    // The four pixels' (x, y) shift pairs, de-interleaved: [x0 y0 x1 y1], [x2 y2 x3 y3] ->
    // [x0 x2 x1 x3], [y0 y2 y1 y3] -> lane order.
    const __m256d pairs01 = _mm256_loadu_pd(m.shift + 2 * x), pairs23 = _mm256_loadu_pd(m.shift + 2 * x + 4);
    const __m256d shift_x = _mm256_permute4x64_pd(_mm256_unpacklo_pd(pairs01, pairs23), 0xd8);
    const __m256d shift_y = _mm256_permute4x64_pd(_mm256_unpackhi_pd(pairs01, pairs23), 0xd8);
    const __m256d columns =
        _mm256_add_pd(_mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(x), _mm_setr_epi32(0, 1, 2, 3))), shift_x);
    const __m256d sx = _mm256_min_pd(_mm256_max_pd(columns, zero), last_column);
    const __m256d sy = _mm256_min_pd(_mm256_max_pd(_mm256_add_pd(row_y, shift_y), zero), last_row);
    const __m128i x0 = _mm256_cvttpd_epi32(sx), y0 = _mm256_cvttpd_epi32(sy);
    const __m128i x1 = _mm_min_epi32(_mm_add_epi32(x0, one_i), width_minus_1);
    const __m128i y1 = _mm_min_epi32(_mm_add_epi32(y0, one_i), height_minus_1);
    const __m256d fx = _mm256_sub_pd(sx, _mm256_cvtepi32_pd(x0)), fy = _mm256_sub_pd(sy, _mm256_cvtepi32_pd(y0));
    const __m128i upper = _mm_mullo_epi32(y0, width_i), lower = _mm_mullo_epi32(y1, width_i);
    const __m256d i00 = _mm256_cvtps_pd(_mm_i32gather_ps(m.inverse_depth, _mm_add_epi32(upper, x0), 4));
    const __m256d i10 = _mm256_cvtps_pd(_mm_i32gather_ps(m.inverse_depth, _mm_add_epi32(upper, x1), 4));
    const __m256d i01 = _mm256_cvtps_pd(_mm_i32gather_ps(m.inverse_depth, _mm_add_epi32(lower, x0), 4));
    const __m256d i11 = _mm256_cvtps_pd(_mm_i32gather_ps(m.inverse_depth, _mm_add_epi32(lower, x1), 4));
    const __m256d any_zero =
        _mm256_or_pd(_mm256_or_pd(_mm256_cmp_pd(i00, zero, _CMP_EQ_OQ), _mm256_cmp_pd(i10, zero, _CMP_EQ_OQ)),
                     _mm256_or_pd(_mm256_cmp_pd(i01, zero, _CMP_EQ_OQ), _mm256_cmp_pd(i11, zero, _CMP_EQ_OQ)));
    valid = _mm256_andnot_pd(any_zero, valid);
    const __m256d wx0 = _mm256_sub_pd(one, fx), wy0 = _mm256_sub_pd(one, fy);
    const __m256d inv =
        _mm256_add_pd(_mm256_mul_pd(wy0, _mm256_add_pd(_mm256_mul_pd(wx0, i00), _mm256_mul_pd(fx, i10))),
                      _mm256_mul_pd(fy, _mm256_add_pd(_mm256_mul_pd(wx0, i01), _mm256_mul_pd(fx, i11))));
    const __m256d disparity =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(disparity_times_metres, inv), _mm256_loadu_pd(m.disparity_noise + x)),
                      _mm256_loadu_pd(m.speckle_noise + x));
    const __m256d rounded = _mm256_add_pd(disparity, half);
    valid = _mm256_and_pd(valid, _mm256_cmp_pd(rounded, one, _CMP_GE_OQ));
    // K / floor(rounded): the table's entry where it has one (the same correctly rounded quotient of
    // the same operands) and the scalar loop's formula past it. A 4-lane division is cheaper here
    // than the gather it replaces; invalid lanes divide garbage and are masked below.
    const __m256d z_noisy = _mm256_div_pd(disparity_times_metres, _mm256_floor_pd(rounded));
    valid = _mm256_and_pd(valid, _mm256_and_pd(_mm256_cmp_pd(z_noisy, min_depth, _CMP_NLT_UQ),
                                               _mm256_cmp_pd(z_noisy, max_depth, _CMP_NGT_UQ)));
    // Invalid lanes stay 0, as the row was.
    _mm_storeu_ps(m.noisy_row + x, _mm256_cvtpd_ps(_mm256_and_pd(z_noisy, valid)));
  }
  return end;
}

// handa_row_avx2 for eight pixels per AVX-512 operation, with the same double operations per lane in
// the same order (contraction into FMAs is off for this function: AVX-512 implies FMA, whose single
// rounding would differ). The four inverse depths of a pixel's bilinear lookup come from registers
// instead of gathers where they can: with the Handa shift (sigma 0.5 px) a block of eight pixels
// reads columns x - 2 .. x + 9 of rows y - 2 .. y + 2 unless a shift exceeds 2 px, so the five rows'
// 16-column windows from x - 4 are loaded once and each lookup is a permute of its row's window,
// selected by the pixel's row. A block with a lookup outside the windows (about 1 in 2000 at sigma
// 0.5) gathers as the AVX2 kernel does. The gathers were a fifth of the noise's time.
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")
// GCC 12 reports its own AVX-512 intrinsics' undefined merge sources as "may be used uninitialized"
// (bug 105593).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
__attribute__((target("avx512f,avx512dq,avx2"))) int handa_row_avx512(const RowModel& m) {
  const int end = m.width / 8 * 8;
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0), half = _mm512_set1_pd(0.5);
  const __m512d last_column = _mm512_set1_pd(double(m.width - 1)), last_row = _mm512_set1_pd(double(m.height - 1));
  const __m512d min_cos = _mm512_set1_pd(m.min_cos), min_depth = _mm512_set1_pd(m.min_depth),
                max_depth = _mm512_set1_pd(m.max_depth);
  const __m512d disparity_times_metres = _mm512_set1_pd(kDisparityTimesMetres);
  const __m256i width_minus_1 = _mm256_set1_epi32(m.width - 1), height_minus_1 = _mm256_set1_epi32(m.height - 1);
  const __m256i width_i = _mm256_set1_epi32(m.width), one_i = _mm256_set1_epi32(1);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m512d row_y = _mm512_set1_pd(double(m.y));
  // The shift pairs (x, y) of eight pixels, de-interleaved from two registers of four pairs each.
  const __m512i even = _mm512_setr_epi64(0, 2, 4, 6, 8, 10, 12, 14), odd = _mm512_setr_epi64(1, 3, 5, 7, 9, 11, 13, 15);
  // Rows y - 2 .. y + 2 (window row r is image row y - 2 + r), null where outside the image: a
  // clamped lookup never selects those.
  const float* window_rows[5];
  for (int r = 0; r < 5; ++r) {
    const int image_row = m.y - 2 + r;
    window_rows[r] =
        image_row >= 0 && image_row < m.height ? m.inverse_depth + std::size_t(image_row) * m.width : nullptr;
  }
  const __m256i first_window_row = _mm256_set1_epi32(m.y - 2);
  for (int x = 0; x < end; x += 8) {
    const __m512d z_clean = _mm512_cvtps_pd(_mm256_loadu_ps(m.clean_row + x));
    const __m512d cos_incidence = _mm512_cvtps_pd(_mm256_loadu_ps(m.incidence_row + x));
    // Lane k has no hole where byte k of the hole flags is 0.
    const __mmask8 no_hole = _mm512_cmpeq_epi64_mask(
        _mm512_cvtepu8_epi64(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(m.speckle_hole + x))),
        _mm512_setzero_si512());
    // !(z <= 0) && !(cos < min_cos) && no hole, as the scalar test's negation.
    __mmask8 valid = _mm512_cmp_pd_mask(z_clean, zero, _CMP_NLE_UQ) &
                     _mm512_cmp_pd_mask(cos_incidence, min_cos, _CMP_NLT_UQ) & no_hole;
    if (valid == 0) continue;

    const __m512d pairs0 = _mm512_loadu_pd(m.shift + 2 * x), pairs1 = _mm512_loadu_pd(m.shift + 2 * x + 8);
    const __m512d shift_x = _mm512_permutex2var_pd(pairs0, even, pairs1);
    const __m512d shift_y = _mm512_permutex2var_pd(pairs0, odd, pairs1);
    const __m512d columns = _mm512_add_pd(_mm512_cvtepi32_pd(_mm256_add_epi32(_mm256_set1_epi32(x), lane)), shift_x);
    const __m512d sx = _mm512_min_pd(_mm512_max_pd(columns, zero), last_column);
    const __m512d sy = _mm512_min_pd(_mm512_max_pd(_mm512_add_pd(row_y, shift_y), zero), last_row);
    const __m256i x0 = _mm512_cvttpd_epi32(sx), y0 = _mm512_cvttpd_epi32(sy);
    const __m256i x1 = _mm256_min_epi32(_mm256_add_epi32(x0, one_i), width_minus_1);
    const __m256i y1 = _mm256_min_epi32(_mm256_add_epi32(y0, one_i), height_minus_1);
    const __m512d fx = _mm512_sub_pd(sx, _mm512_cvtepi32_pd(x0)), fy = _mm512_sub_pd(sy, _mm512_cvtepi32_pd(y0));

    // Window coordinates: column from x - 4 (0 .. 15 inside), row from y - 2 (0 .. 4 inside).
    const __m256i window_x = _mm256_set1_epi32(x - 4);
    const __m256i column0 = _mm256_sub_epi32(x0, window_x), column1 = _mm256_sub_epi32(x1, window_x);
    const __m256i row0 = _mm256_sub_epi32(y0, first_window_row), row1 = _mm256_sub_epi32(y1, first_window_row);
    // Unsigned <= tests: a negative coordinate is a large unsigned one.
    const __m256i inside = _mm256_and_si256(
        _mm256_and_si256(_mm256_cmpeq_epi32(_mm256_min_epu32(column0, _mm256_set1_epi32(15)), column0),
                         _mm256_cmpeq_epi32(_mm256_min_epu32(column1, _mm256_set1_epi32(15)), column1)),
        _mm256_and_si256(_mm256_cmpeq_epi32(_mm256_min_epu32(row0, _mm256_set1_epi32(4)), row0),
                         _mm256_cmpeq_epi32(_mm256_min_epu32(row1, _mm256_set1_epi32(4)), row1)));
    const __mmask8 outside_windows = __mmask8(~_mm256_movemask_ps(_mm256_castsi256_ps(inside))) & valid;
    __m256 f00, f10, f01, f11;
    if (outside_windows == 0) {
      // Columns x - 4 .. x + 11 of each row, those outside the image masked off (never selected).
      const int before = std::max(0, 4 - x), after = std::max(0, x + 12 - m.width);
      const __mmask16 in_image = __mmask16((0xFFFFu << before) & (0xFFFFu >> after));
      const __m512i index0 = _mm512_castsi256_si512(column0), index1 = _mm512_castsi256_si512(column1);
      const __m512i row0_wide = _mm512_castsi256_si512(row0), row1_wide = _mm512_castsi256_si512(row1);
      __m512 v00 = _mm512_setzero_ps(), v10 = v00, v01 = v00, v11 = v00;
      for (int r = 0; r < 5; ++r) {
        if (!window_rows[r]) continue;
        const __m512 window = _mm512_maskz_loadu_ps(in_image, window_rows[r] + x - 4);
        const __m512i r_wide = _mm512_set1_epi32(r);
        const __mmask16 upper = _mm512_cmpeq_epi32_mask(row0_wide, r_wide) & 0xFF,
                        lower = _mm512_cmpeq_epi32_mask(row1_wide, r_wide) & 0xFF;
        v00 = _mm512_mask_permutexvar_ps(v00, upper, index0, window);
        v10 = _mm512_mask_permutexvar_ps(v10, upper, index1, window);
        v01 = _mm512_mask_permutexvar_ps(v01, lower, index0, window);
        v11 = _mm512_mask_permutexvar_ps(v11, lower, index1, window);
      }
      f00 = _mm512_castps512_ps256(v00);
      f10 = _mm512_castps512_ps256(v10);
      f01 = _mm512_castps512_ps256(v01);
      f11 = _mm512_castps512_ps256(v11);
    } else {
      const __m256i upper = _mm256_mullo_epi32(y0, width_i), lower = _mm256_mullo_epi32(y1, width_i);
      f00 = _mm256_i32gather_ps(m.inverse_depth, _mm256_add_epi32(upper, x0), 4);
      f10 = _mm256_i32gather_ps(m.inverse_depth, _mm256_add_epi32(upper, x1), 4);
      f01 = _mm256_i32gather_ps(m.inverse_depth, _mm256_add_epi32(lower, x0), 4);
      f11 = _mm256_i32gather_ps(m.inverse_depth, _mm256_add_epi32(lower, x1), 4);
    }
    const __m512d i00 = _mm512_cvtps_pd(f00), i10 = _mm512_cvtps_pd(f10), i01 = _mm512_cvtps_pd(f01),
                  i11 = _mm512_cvtps_pd(f11);
    valid &= __mmask8(~(_mm512_cmp_pd_mask(i00, zero, _CMP_EQ_OQ) | _mm512_cmp_pd_mask(i10, zero, _CMP_EQ_OQ) |
                        _mm512_cmp_pd_mask(i01, zero, _CMP_EQ_OQ) | _mm512_cmp_pd_mask(i11, zero, _CMP_EQ_OQ)));
    const __m512d wx0 = _mm512_sub_pd(one, fx), wy0 = _mm512_sub_pd(one, fy);
    const __m512d inv =
        _mm512_add_pd(_mm512_mul_pd(wy0, _mm512_add_pd(_mm512_mul_pd(wx0, i00), _mm512_mul_pd(fx, i10))),
                      _mm512_mul_pd(fy, _mm512_add_pd(_mm512_mul_pd(wx0, i01), _mm512_mul_pd(fx, i11))));
    const __m512d disparity =
        _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(disparity_times_metres, inv), _mm512_loadu_pd(m.disparity_noise + x)),
                      _mm512_loadu_pd(m.speckle_noise + x));
    const __m512d rounded = _mm512_add_pd(disparity, half);
    valid &= _mm512_cmp_pd_mask(rounded, one, _CMP_GE_OQ);
    const __m512d z_noisy =
        _mm512_div_pd(disparity_times_metres, _mm512_roundscale_pd(rounded, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC));
    valid &= _mm512_cmp_pd_mask(z_noisy, min_depth, _CMP_NLT_UQ) & _mm512_cmp_pd_mask(z_noisy, max_depth, _CMP_NGT_UQ);
    // Invalid lanes stay 0, as the row was.
    _mm256_storeu_ps(m.noisy_row + x, _mm512_cvtpd_ps(_mm512_maskz_mov_pd(valid, z_noisy)));
  }
  return end;
}
#pragma GCC diagnostic pop
#pragma GCC pop_options
#endif

}  // namespace

double disparity_model_depth_std(double z_m, double disparity_std) {
  // dZ/dd = Z^2 / 351.3; rounding adds a uniform 1/12 units^2 averaged over the phase.
  return z_m * z_m / kDisparityTimesMetres * std::sqrt(disparity_std * disparity_std + 1.0 / 12.0);
}

double handa_depth_std(double z_m) { return disparity_model_depth_std(z_m, 1.0 / 6.0); }

bool depth_valid(double z_m, double incidence_cos, const NoiseOptions& options) {
  return z_m >= options.min_depth_m && z_m <= options.max_depth_m &&
         incidence_cos >= std::cos(deg2rad(options.max_incidence_deg));
}

ImageF32 apply_depth_noise(const DepthNoiseInput& input, const NoiseOptions& options, std::uint64_t seed) {
  const ImageF32& clean = *input.clean_depth;
  const ImageF32& incidence = *input.incidence_cos;
  const PinholeIntrinsics& k = *input.intrinsics;
  const int width = clean.width, height = clean.height;
  ImageF32 noisy(width, height, 1, 0.0f);
  const double disparity_std = options.effective_disparity_std();
  const bool noisy_preset = options.preset != NoisePreset::kNone;
  const bool lateral = options.preset == NoisePreset::kHandaIcl;
  const int band_rows = static_cast<int>(std::lround(options.ir_band_fraction * height));
  const double min_cos = std::cos(deg2rad(options.max_incidence_deg));
  const std::vector<double>& depth_of_disparity = depth_of_disparity_table();

  // Inverse depth per pixel, 0 where the sensor has no measurement (no hit, or outside its
  // range): such a pixel invalidates every lookup that touches it. Computed once per frame so
  // that the per-pixel lookup needs no division. The float quotient is the double one rounded to
  // float (double carries more than twice float's precision), and unlike it vectorises.
  // Computed rows in parallel, before the model (whose lookups reach into neighbouring rows); it was a
  // serial pass between two parallel ones.
  ImageF32 inverse_depth = ImageF32::uninitialised(width, height, 1);  // every pixel written below
  const double min_depth = options.min_depth_m, max_depth = options.max_depth_m;
  tbb::parallel_for(tbb::blocked_range<int>(0, height, 16), [&](const tbb::blocked_range<int>& rows) {
    const std::size_t end = std::size_t(rows.end()) * width;
    for (std::size_t i = std::size_t(rows.begin()) * width; i < end; ++i) {
      const float z = clean.data[i];
      const bool in_range = double(z) >= min_depth && double(z) <= max_depth;
      inverse_depth.data[i] = in_range ? 1.0f / z : 0.0f;
    }
  });

  if (!noisy_preset) {
    for (std::size_t i = 0; i < clean.data.size(); ++i) {
      const double z_clean = clean.data[i];
      if (z_clean > 0 && depth_valid(z_clean, incidence.data[i], options)) noisy.data[i] = float(z_clean);
    }
    return noisy;
  }

  const double shift_std = options.shift_std_px;
#if PANOSCAN_NOISE_AVX2
  const bool use_avx512 = cpu::has_avx512dq() && input.kernel == DepthNoiseInput::Kernel::kFastest;
  const bool use_avx2 = cpu::has_avx2() && input.kernel != DepthNoiseInput::Kernel::kScalar;
#endif
  const double ir_dropout = options.ir_dropout, ir_disparity_std = options.ir_disparity_std;
  // Each row draws its deviates first, one bulk stream per (purpose, row) (BulkNormalStream: eight
  // generators in the vector lanes), then the model runs over the row. The streams are keyed by
  // row, so the noise does not depend on how rows are scheduled, and the model's loop is free of
  // the generators (which lets it run four or eight pixels per vector operation).
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    // The shift stream's draws alternate x and y per pixel: shifts[2x], [2x + 1].
    std::vector<double> shifts(2 * std::size_t(width)), disparities(width), laterals(width, 0.0);
    std::vector<double> speckle_noise(width, 0.0);
    std::vector<std::uint8_t> speckle_hole(width, 0);
    for (int y = rows.begin(); y != rows.end(); ++y) {
      // Every variate is drawn for every pixel so that validity never shifts the streams.
      BulkNormalStream(seed, input.sensor, input.frame, RandomPurpose::kDepthShift, y)
          .fill(shifts.size(), shift_std, shifts.data());
      BulkNormalStream(seed, input.sensor, input.frame, RandomPurpose::kDepthDisparity, y)
          .fill(disparities.size(), disparity_std, disparities.data());
      if (lateral)
        BulkNormalStream(seed, input.sensor, input.frame, RandomPurpose::kDepthLateral, y)
            .fill(laterals.size(), 1.0, laterals.data());
      const double* shift = shifts.data();
      const double* disparity_noise = disparities.data();
      const double* lateral_noise = laterals.data();
      const bool in_band = options.ir_speckle && band_rows > 0 &&
                           ((input.speckle_top && y < band_rows) || (input.speckle_bottom && y >= height - band_rows));
      if (in_band) {
        RandomStream speckle_rng(seed, input.sensor, input.frame, RandomPurpose::kSpeckle, y);
        for (int x = 0; x < width; ++x) {
          speckle_hole[x] = speckle_rng.uniform() < ir_dropout;
          speckle_noise[x] = speckle_rng.normal() * ir_disparity_std;
        }
      } else {
        std::fill(speckle_hole.begin(), speckle_hole.end(), std::uint8_t(0));
        std::fill(speckle_noise.begin(), speckle_noise.end(), 0.0);
      }

      const float* clean_row = clean.row(y);
      const float* incidence_row = incidence.row(y);
      float* noisy_row = noisy.row(y);
      int first_scalar = 0;
#if PANOSCAN_NOISE_AVX2
      if (!lateral && use_avx2) {
        const RowModel model{clean_row,
                             incidence_row,
                             inverse_depth.data.data(),
                             speckle_hole.data(),
                             shift,
                             disparity_noise,
                             speckle_noise.data(),
                             noisy_row,
                             width,
                             height,
                             y,
                             min_cos,
                             options.min_depth_m,
                             options.max_depth_m};
        first_scalar = use_avx512 ? handa_row_avx512(model) : handa_row_avx2(model);
      }
#endif
      for (int x = first_scalar; x < width; ++x) {
        const double z_clean = clean_row[x];
        const double cos_incidence = incidence_row[x];
        if (z_clean <= 0 || cos_incidence < min_cos || speckle_hole[x]) continue;

        // Step 1: sub-pixel shift, bilinear interpolation of inverse depth (clamped at the border);
        // a lookup touching an invalid neighbour is invalid.
        const double sx = std::clamp(x + shift[2 * x], 0.0, double(width - 1));
        const double sy = std::clamp(y + shift[2 * x + 1], 0.0, double(height - 1));
        const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
        const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
        const double fx = sx - x0, fy = sy - y0;
        const float* upper = inverse_depth.row(y0);
        const float* lower = inverse_depth.row(y1);
        const double i00 = upper[x0], i10 = upper[x1];
        const double i01 = lower[x0], i11 = lower[x1];
        // The four tests combined without short-circuit branches: each is rarely true, and one
        // branch predicts better than four.
        if ((i00 == 0) | (i10 == 0) | (i01 == 0) | (i11 == 0)) continue;
        double inv = (1 - fy) * ((1 - fx) * i00 + fx * i10) + fy * ((1 - fx) * i01 + fx * i11);

        if (lateral) {
          // handa-icl: displacement along the surface normal with Nguyen et al.'s lateral std
          // sigma_L = (0.8 + 0.035 theta / (pi/2 - theta)) * Z / f; along the ray this moves the
          // range by delta / cos(theta), i.e. z by delta / (cos(theta) * |ray|) for a z-unit ray.
          double z = 1.0 / inv;
          const double c = std::max(cos_incidence, 0.1);
          const double theta = std::acos(std::min(c, 1.0));
          const double sigma_px = 0.8 + 0.035 * theta / std::max(M_PI / 2 - theta, 1e-3);
          const double delta = lateral_noise[x] * sigma_px * z / k.fx;
          const double ray_x = (x - k.cx) / k.fx, ray_y = (y - k.cy) / k.fy;
          z += delta / (c * std::sqrt(1.0 + ray_x * ray_x + ray_y * ray_y));
          if (z <= 0) continue;
          inv = 1.0 / z;
        }

        // Step 2: disparity noise and unbiased rounding to whole disparity units.
        const double disparity = kDisparityTimesMetres * inv + disparity_noise[x] + speckle_noise[x];
        // floor(disparity + 0.5) > 0 exactly when disparity + 0.5 >= 1; below 2^31 the integer
        // conversion truncates, which for positive values is the floor (std::floor is a libm
        // sequence on the baseline x86-64 target).
        const double rounded = disparity + 0.5;
        if (!(rounded >= 1.0)) continue;
        double z_noisy;
        if (rounded < double(kDepthTableSize)) {
          z_noisy = depth_of_disparity[static_cast<int>(rounded)];
        } else {
          z_noisy = kDisparityTimesMetres / std::floor(rounded);
        }
        // Step 3: sensor range.
        if (z_noisy < min_depth || z_noisy > max_depth) continue;
        noisy_row[x] = static_cast<float>(z_noisy);
      }
    }
  });
  return noisy;
}

}  // namespace panoscan
