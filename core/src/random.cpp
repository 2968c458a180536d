#include "panoscan/core/random.h"
#include "panoscan/core/cpu_features.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PANOSCAN_RANDOM_AVX512 1
#endif

namespace panoscan {

std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

RandomStream::RandomStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                           std::int64_t lane)
    : ziggurat_(&detail::ziggurat_tables()) {
  // Chain the key parts through the mixer so that nearby keys give unrelated states.
  std::uint64_t h = mix64(seed);
  h = mix64(h ^ static_cast<std::uint64_t>(camera + 0x1234));
  h = mix64(h ^ static_cast<std::uint64_t>(frame + 0x5678));
  h = mix64(h ^ static_cast<std::uint64_t>(purpose));
  h = mix64(h ^ static_cast<std::uint64_t>(lane + 0x9ABC));
  for (auto& s : state_) {
    h = mix64(h);
    s = h;
  }
}

double RandomStream::uniform() { return static_cast<double>(next_u64() >> 11) * 0x1.0p-53; }

double RandomStream::uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

int RandomStream::uniform_int(int lo, int hi_inclusive) {
  const std::uint64_t span = static_cast<std::uint64_t>(hi_inclusive - lo) + 1;
  return lo + static_cast<int>(next_u64() % span);
}

namespace detail {

ZigguratTables::ZigguratTables() {
  auto f = [](double x) { return std::exp(-0.5 * x * x); };
  width[0] = kLayerArea / f(kTailStart);
  width[1] = kTailStart;
  for (int i = 2; i < kLayers; ++i) width[i] = std::sqrt(-2.0 * std::log(kLayerArea / width[i - 1] + f(width[i - 1])));
  width[kLayers] = 0.0;
  for (int i = 0; i <= kLayers; ++i) height[i] = f(width[i]);
}

const ZigguratTables& ziggurat_tables() {
  static const ZigguratTables tables;
  return tables;
}

}  // namespace detail

double RandomStream::normal_outside_core(std::uint64_t bits) {
  const detail::ZigguratTables& z = *ziggurat_;
  for (;;) {
    const int layer = static_cast<int>(bits & 127u);
    const double sign = (bits & 128u) ? -1.0 : 1.0;
    const double u = static_cast<double>(bits >> 11) * 0x1.0p-53;
    const double x = u * z.width[layer];
    if (x < z.width[layer + 1]) return sign * x;  // inside the rectangle's core (a redraw)
    if (layer == 0) {
      // Tail beyond r (Marsaglia 1964).
      double a, b;
      do {
        a = -std::log(1.0 - uniform()) / detail::ZigguratTables::kTailStart;
        b = -std::log(1.0 - uniform());
      } while (2.0 * b < a * a);
      return sign * (detail::ZigguratTables::kTailStart + a);
    }
    // Wedge between the rectangle and the curve.
    const double y = z.height[layer] + uniform() * (z.height[layer + 1] - z.height[layer]);
    if (y < std::exp(-0.5 * x * x)) return sign * x;
    bits = next_u64();
  }
}

}  // namespace panoscan

namespace panoscan {

#if PANOSCAN_RANDOM_AVX512
// GCC 12's AVX-512 intrinsics pass _mm512_undefined_epi32() as the unused merge source, which it then
// reports as "may be used uninitialized" where they inline into a target("avx512f") function (GCC
// bug 105593): silenced for this section only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
namespace {


// Rows r of the 8 x 8 doubles in `rows` become columns.
__attribute__((target("avx512f,avx512dq"))) inline void transpose8(__m512d rows[8]) {
  __m512d pairs[8], quads[8];
  for (int i = 0; i < 8; i += 2) {
    pairs[i] = _mm512_unpacklo_pd(rows[i], rows[i + 1]);      // r_i0 r_j0 r_i2 r_j2 | ...
    pairs[i + 1] = _mm512_unpackhi_pd(rows[i], rows[i + 1]);  // r_i1 r_j1 r_i3 r_j3 | ...
  }
  // 128-bit blocks: (0, 2) of a and (0, 2) of b, and (1, 3) of each.
  for (int i = 0; i < 8; i += 4)
    for (int k = 0; k < 2; ++k) {
      quads[i + k] = _mm512_shuffle_f64x2(pairs[i + k], pairs[i + 2 + k], 0x88);
      quads[i + 2 + k] = _mm512_shuffle_f64x2(pairs[i + k], pairs[i + 2 + k], 0xdd);
    }
  for (int k = 0; k < 4; ++k) {
    rows[k] = _mm512_shuffle_f64x2(quads[k], quads[4 + k], 0x88);
    rows[4 + k] = _mm512_shuffle_f64x2(quads[k], quads[4 + k], 0xdd);
  }
}

}  // namespace

// draw_normals for exactly eight streams, one per AVX-512 lane: xoshiro256** and the ziggurat's
// common path as RandomStream::next_u64 and normal compute them (integer steps; u from the top 53
// bits converted exactly; x = u * width[layer] and the compare in double, as the scalar code).
// Blocks of eight draws per stream run without a branch, as if every draw fell inside its layer's
// core; a lane whose draw did not (2.8% of draws, one lane or more in 20% of steps) is redrawn from
// that draw on by the scalar normal(), from its state at the block's start stepped past the draws
// before it, and goes on from where the scalar code left its stream. Every stream gives its own
// sequence. A branch per step on the rare path (before) was mispredicted in a fifth of the steps,
// and each time the work after the gathers the branch waited for was thrown away: 2.7 ns per
// deviate against 0.56 ns without it. Returns how many of the n draws it made (a multiple of 8);
// the caller draws the rest.
__attribute__((target("avx512f,avx512dq"))) std::size_t draw_normals_lanes(RandomStream* streams, std::size_t n,
                                                                           double scale, double* const* out) {
  alignas(64) std::uint64_t state[4][8];
  for (int k = 0; k < 4; ++k)
    for (int lane = 0; lane < 8; ++lane) state[k][lane] = streams[lane].state_[k];
  __m512i s0 = _mm512_load_si512(state[0]), s1 = _mm512_load_si512(state[1]), s2 = _mm512_load_si512(state[2]),
          s3 = _mm512_load_si512(state[3]);
  const detail::ZigguratTables& z = detail::ziggurat_tables();
  const __m512i layer_mask = _mm512_set1_epi64(127), sign_bit = _mm512_set1_epi64(128);
  const __m512d unit = _mm512_set1_pd(0x1.0p-53), scales = _mm512_set1_pd(scale);
  const std::size_t whole = n / 8 * 8;
  for (std::size_t i = 0; i < whole; i += 8) {
    const __m512i start0 = s0, start1 = s1, start2 = s2, start3 = s3;
    __m512d draws[8];
    __mmask8 outside_at[8];
    for (int step = 0; step < 8; ++step) {
      // xoshiro256**: result = rotl(s1 * 5, 7) * 9, then the state update.
      const __m512i times5 = _mm512_add_epi64(s1, _mm512_slli_epi64(s1, 2));
      const __m512i rotated = _mm512_rol_epi64(times5, 7);
      const __m512i bits = _mm512_add_epi64(rotated, _mm512_slli_epi64(rotated, 3));
      const __m512i t = _mm512_slli_epi64(s1, 17);
      s2 = _mm512_xor_si512(s2, s0);
      s3 = _mm512_xor_si512(s3, s1);
      s1 = _mm512_xor_si512(s1, s2);
      s0 = _mm512_xor_si512(s0, s3);
      s2 = _mm512_xor_si512(s2, t);
      s3 = _mm512_rol_epi64(s3, 45);
      // The ziggurat's core: x = u * width[layer], kept where x < width[layer + 1].
      const __m512i layer = _mm512_and_si512(bits, layer_mask);
      const __m512d u = _mm512_mul_pd(_mm512_cvtepu64_pd(_mm512_srli_epi64(bits, 11)), unit);
      const __m512d x = _mm512_mul_pd(u, _mm512_i64gather_pd(layer, z.width, 8));
      outside_at[step] = _mm512_cmp_pd_mask(x, _mm512_i64gather_pd(layer, z.width + 1, 8), _CMP_NLT_UQ);
      const __m512d value = _mm512_castsi512_pd(
          _mm512_xor_si512(_mm512_castpd_si512(x), _mm512_slli_epi64(_mm512_and_si512(bits, sign_bit), 56)));
      draws[step] = _mm512_mul_pd(value, scales);
    }
    // draws[step] holds draw i + step of every stream; stream `lane` wants its eight in a row.
    transpose8(draws);
    for (int lane = 0; lane < 8; ++lane) _mm512_storeu_pd(out[lane] + i, draws[lane]);
    __mmask8 outside = 0;
    for (int step = 0; step < 8; ++step) outside |= outside_at[step];
    if (outside == 0) continue;
    // The lanes with a draw outside its core: redrawn by the scalar code from that draw on.
    alignas(64) std::uint64_t start[4][8];
    _mm512_store_si512(start[0], start0);
    _mm512_store_si512(start[1], start1);
    _mm512_store_si512(start[2], start2);
    _mm512_store_si512(start[3], start3);
    for (unsigned lanes = outside; lanes; lanes &= lanes - 1) {
      const int lane = __builtin_ctz(lanes);
      const __mmask8 lane_mask = __mmask8(1u << lane);
      RandomStream& stream = streams[lane];
      for (int k = 0; k < 4; ++k) stream.state_[k] = start[k][lane];
      int first = 0;
      while (!(outside_at[first] & lane_mask)) ++first;
      for (int step = 0; step < first; ++step) stream.next_u64();  // the draws before were in their cores
      for (int step = first; step < 8; ++step) out[lane][i + std::size_t(step)] = stream.normal() * scale;
      s0 = _mm512_mask_set1_epi64(s0, lane_mask, (long long)stream.state_[0]);
      s1 = _mm512_mask_set1_epi64(s1, lane_mask, (long long)stream.state_[1]);
      s2 = _mm512_mask_set1_epi64(s2, lane_mask, (long long)stream.state_[2]);
      s3 = _mm512_mask_set1_epi64(s3, lane_mask, (long long)stream.state_[3]);
    }
  }
  _mm512_store_si512(state[0], s0);
  _mm512_store_si512(state[1], s1);
  _mm512_store_si512(state[2], s2);
  _mm512_store_si512(state[3], s3);
  for (int k = 0; k < 4; ++k)
    for (int lane = 0; lane < 8; ++lane) streams[lane].state_[k] = state[k][lane];
  return whole;
}
#pragma GCC diagnostic pop
#endif

void draw_normals(RandomStream* streams, std::size_t count, std::size_t n, double scale, double* const* out) {
  std::size_t first = 0;  // the first stream the scalar loop below draws from
#if PANOSCAN_RANDOM_AVX512
  if (cpu::has_avx512dq() && count >= 8) {
    std::size_t drawn = 0;
    for (; first + 8 <= count; first += 8) {
      drawn = draw_normals_lanes(streams + first, n, scale, out + first);
      for (std::size_t s = first; s < first + 8; ++s)
        for (std::size_t i = drawn; i < n; ++i) out[s][i] = streams[s].normal() * scale;
    }
  }
#endif
  for (std::size_t s = first; s < count; ++s)
    for (std::size_t i = 0; i < n; ++i) out[s][i] = streams[s].normal() * scale;
}

}  // namespace panoscan
