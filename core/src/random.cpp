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

namespace {

// normal()'s rare path for a draw `bits` outside its layer's core, with `next_bits` giving the
// stream's following draws: the tail or the wedge, and further draws while they are rejected.
// Shared by RandomStream::normal (draws from the generator) and draw_normals (draws made ahead).
template <class NextBits>
double normal_outside_core_from(const detail::ZigguratTables& z, std::uint64_t bits, NextBits&& next_bits) {
  const auto uniform = [&] { return static_cast<double>(next_bits() >> 11) * 0x1.0p-53; };
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
    bits = next_bits();
  }
}

}  // namespace

double RandomStream::normal_outside_core(std::uint64_t bits) {
  return normal_outside_core_from(*ziggurat_, bits, [this] { return next_u64(); });
}

// Not inlined into draw_normals_lanes: compiled there, for AVX-512, GCC would contract the wedge's
// multiply-adds into FMAs, whose rounding differs from normal()'s.
__attribute__((noinline)) std::size_t RandomStream::normals_from_draws(const std::uint64_t* bits,
                                                                       const double* scaled_core,
                                                                       const std::uint64_t* outside, std::size_t count,
                                                                       double scale, double* out) {
  std::size_t next = 0, made = 0;
  while (next < count) {
    // The next draw at or after `next` outside its core, or `count`.
    std::size_t outside_at = count;
    for (std::size_t word = next / 64; word * 64 < count; ++word) {
      std::uint64_t mask = outside[word];
      if (word * 64 < next) mask &= ~std::uint64_t(0) << (next - word * 64);
      if (mask) {
        outside_at = std::min(count, word * 64 + std::size_t(__builtin_ctzll(mask)));
        break;
      }
    }
    std::memcpy(out + made, scaled_core + next, sizeof(double) * (outside_at - next));
    made += outside_at - next;
    if (outside_at == count) break;
    next = outside_at + 1;
    out[made++] = normal_outside_core_from(*ziggurat_, bits[outside_at],
                                           [&] { return next < count ? bits[next++] : (++next, next_u64()); }) *
                  scale;
  }
  return made;
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

// Transposes the 8 x 8 bit matrix whose row r is byte r of `bits`: bit 8r + c goes to 8c + r (three
// delta swaps, Hacker's Delight 7-3).
inline std::uint64_t transpose_bits8(std::uint64_t bits) {
  std::uint64_t t = (bits ^ (bits >> 7)) & 0x00AA00AA00AA00AAull;
  bits ^= t ^ (t << 7);
  t = (bits ^ (bits >> 14)) & 0x0000CCCC0000CCCCull;
  bits ^= t ^ (t << 14);
  t = (bits ^ (bits >> 28)) & 0x00000000F0F0F0F0ull;
  return bits ^ t ^ (t << 28);
}

}  // namespace

// draw_normals for exactly eight streams, one per AVX-512 lane. Each round makes `chunk` draws per
// stream in the lanes: xoshiro256** and the ziggurat's common path as RandomStream::next_u64 and
// normal compute them (integer steps; u from the top 53 bits converted exactly; x = u *
// width[layer] and the compare in double, as the scalar code), without a branch, keeping each
// draw's bits, its value were it inside its layer's core, and whether it is. Then each stream turns
// its draws into deviates (normals_from_draws): the values in order, and for a draw outside its
// core (2.8% of draws) the tail or the wedge, which read the draws that follow it as normal()'s
// further draws do. A stream never has more draws made than it can use (`chunk` is at most the
// fewest deviates any stream still lacks, as every draw gives at most one deviate), so every
// stream's state ends where the scalar calls leave it. `written[lane]`: how many of the n deviates
// stream `lane` has; the caller makes the rest (fewer than 8, plus the draws its rare paths used).
// Before (session 39), a lane with a rare draw redrew the rest of its eight-draw block with the
// scalar code (2.33 ns per deviate); a branch per step before that was mispredicted in a fifth of
// the steps (2.7 ns).
__attribute__((target("avx512f,avx512dq"))) void draw_normals_lanes(RandomStream* streams, std::size_t n, double scale,
                                                                    double* const* out, std::size_t* written) {
  // Per round and stream: 128 draws' bits and values (2 KB), in L1 for the stream's pass.
  constexpr std::size_t kChunk = 128;
  alignas(64) std::uint64_t draw_bits[8][kChunk];
  alignas(64) double scaled_core[8][kChunk];
  // Zeroed once: past `chunk`, a round's last word may hold an earlier round's bits, which it ignores.
  alignas(64) std::uint64_t outside[8][kChunk / 64] = {};
  const detail::ZigguratTables& z = detail::ziggurat_tables();
  const __m512i layer_mask = _mm512_set1_epi64(127), sign_bit = _mm512_set1_epi64(128);
  const __m512d unit = _mm512_set1_pd(0x1.0p-53), scales = _mm512_set1_pd(scale);
  for (int lane = 0; lane < 8; ++lane) written[lane] = 0;
  for (;;) {
    const std::size_t most_written = *std::max_element(written, written + 8);
    const std::size_t chunk = std::min(kChunk, (n - most_written) / 8 * 8);
    if (chunk == 0) break;
    alignas(64) std::uint64_t state[4][8];
    for (int k = 0; k < 4; ++k)
      for (int lane = 0; lane < 8; ++lane) state[k][lane] = streams[lane].state_[k];
    __m512i s0 = _mm512_load_si512(state[0]), s1 = _mm512_load_si512(state[1]), s2 = _mm512_load_si512(state[2]),
            s3 = _mm512_load_si512(state[3]);
    for (std::size_t i = 0; i < chunk; i += 8) {
      __m512d values[8], bits_of[8];
      std::uint64_t outside_by_step = 0;  // byte `step`: the lanes whose draw is outside its core
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
        // The ziggurat's core: x = u * width[layer], inside where x < width[layer + 1].
        const __m512i layer = _mm512_and_si512(bits, layer_mask);
        const __m512d u = _mm512_mul_pd(_mm512_cvtepu64_pd(_mm512_srli_epi64(bits, 11)), unit);
        const __m512d x = _mm512_mul_pd(u, _mm512_i64gather_pd(layer, z.width, 8));
        const __mmask8 outside_now = _mm512_cmp_pd_mask(x, _mm512_i64gather_pd(layer, z.width + 1, 8), _CMP_NLT_UQ);
        outside_by_step |= std::uint64_t(outside_now) << (8 * step);
        const __m512d value = _mm512_castsi512_pd(
            _mm512_xor_si512(_mm512_castpd_si512(x), _mm512_slli_epi64(_mm512_and_si512(bits, sign_bit), 56)));
        values[step] = _mm512_mul_pd(value, scales);
        bits_of[step] = _mm512_castsi512_pd(bits);
      }
      // values[step] holds draw i + step of every stream; each stream wants its eight in a row.
      transpose8(values);
      transpose8(bits_of);
      const std::uint64_t outside_by_lane = transpose_bits8(outside_by_step);  // byte `lane`: its steps
      for (int lane = 0; lane < 8; ++lane) {
        _mm512_store_pd(scaled_core[lane] + i, values[lane]);
        _mm512_store_pd(reinterpret_cast<double*>(draw_bits[lane] + i), bits_of[lane]);
        reinterpret_cast<unsigned char*>(outside[lane])[i / 8] =
            static_cast<unsigned char>(outside_by_lane >> (8 * lane));
      }
    }
    _mm512_store_si512(state[0], s0);
    _mm512_store_si512(state[1], s1);
    _mm512_store_si512(state[2], s2);
    _mm512_store_si512(state[3], s3);
    for (int k = 0; k < 4; ++k)
      for (int lane = 0; lane < 8; ++lane) streams[lane].state_[k] = state[k][lane];
    for (int lane = 0; lane < 8; ++lane)
      written[lane] += streams[lane].normals_from_draws(draw_bits[lane], scaled_core[lane], outside[lane], chunk, scale,
                                                        out[lane] + written[lane]);
  }
}
#pragma GCC diagnostic pop
#endif

void draw_normals(RandomStream* streams, std::size_t count, std::size_t n, double scale, double* const* out) {
  std::size_t first = 0;  // the first stream the scalar loop below draws from
#if PANOSCAN_RANDOM_AVX512
  if (cpu::has_avx512dq() && count >= 8) {
    for (; first + 8 <= count; first += 8) {
      std::size_t written[8];
      draw_normals_lanes(streams + first, n, scale, out + first, written);
      for (std::size_t s = first; s < first + 8; ++s)
        for (std::size_t i = written[s - first]; i < n; ++i) out[s][i] = streams[s].normal() * scale;
    }
  }
#endif
  for (std::size_t s = first; s < count; ++s)
    for (std::size_t i = 0; i < n; ++i) out[s][i] = streams[s].normal() * scale;
}

}  // namespace panoscan
