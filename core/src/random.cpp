#include "panoscan/core/random.h"
#include "panoscan/core/cpu_features.h"

#include <algorithm>
#include <cmath>

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace panoscan {

std::uint64_t mix64(std::uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

namespace {
// The chained key mix of a stream's key parts: nearby keys give unrelated states.
std::uint64_t key_hash(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                       std::int64_t lane) {
  std::uint64_t h = mix64(seed);
  h = mix64(h ^ static_cast<std::uint64_t>(camera + 0x1234));
  h = mix64(h ^ static_cast<std::uint64_t>(frame + 0x5678));
  h = mix64(h ^ static_cast<std::uint64_t>(purpose));
  return mix64(h ^ static_cast<std::uint64_t>(lane + 0x9ABC));
}
}  // namespace

RandomStream::RandomStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                           std::int64_t lane)
    : RandomStream(key_hash(seed, camera, frame, purpose, lane)) {}

RandomStream::RandomStream(std::uint64_t key) : ziggurat_(&detail::ziggurat_tables()) {
  std::uint64_t h = key;
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

namespace {
// The layers of a ziggurat for f(x) = exp(-x^2/2) with `layers` layers of area `area` and the tail
// from `tail_start` (Marsaglia & Tsang 2000): width[0] = v / f(r) (the base strip), width[1] = r,
// then each layer's top edge from the area; width[layers] = 0. height = f(width).
void ziggurat_layers(int layers, double tail_start, double area, double* width, double* height) {
  auto f = [](double x) { return std::exp(-0.5 * x * x); };
  width[0] = area / f(tail_start);
  width[1] = tail_start;
  for (int i = 2; i < layers; ++i) width[i] = std::sqrt(-2.0 * std::log(area / width[i - 1] + f(width[i - 1])));
  width[layers] = 0.0;
  for (int i = 0; i <= layers; ++i) height[i] = f(width[i]);
}
}  // namespace

ZigguratTables::ZigguratTables() { ziggurat_layers(kLayers, kTailStart, kLayerArea, width, height); }

const ZigguratTables& ziggurat_tables() {
  static const ZigguratTables tables;
  return tables;
}

BulkZigguratTables::BulkZigguratTables() {
  ziggurat_layers(kLayers, kTailStart, kLayerArea, width, height);
  for (int i = 0; i < kLayers; ++i) unit_width[i] = width[i] * 0x1.0p-23;  // exact: a power of two
}

const BulkZigguratTables& bulk_ziggurat_tables() {
  static const BulkZigguratTables tables;
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

// ---- BulkNormalStream ----

BulkNormalStream::BulkNormalStream(std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                                   std::int64_t lane)
    : rare_(mix64(key_hash(seed, camera, frame, purpose, lane) ^ 0x5241524552415245ull)) {
  const std::uint64_t key = key_hash(seed, camera, frame, purpose, lane);
  for (int generator = 0; generator < 8; ++generator) {
    std::uint64_t h = mix64(key ^ (0x9E3779B97F4A7C15ull * std::uint64_t(generator + 1)));
    for (int word = 0; word < 4; ++word) {
      h = mix64(h);
      state_[word][generator] = h;
    }
  }
}

namespace {

constexpr std::uint32_t kLayerBits = 0xFFu, kSignBit = 0x100u;
constexpr int kUShift = 9;  // u: the top 23 bits

inline std::uint64_t rotl64(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

}  // namespace

double BulkNormalStream::outside_core(std::uint32_t draw) {
  const detail::BulkZigguratTables& z = detail::bulk_ziggurat_tables();
  const int layer = static_cast<int>(draw & kLayerBits);
  const double sign = (draw & kSignBit) ? -1.0 : 1.0;
  if (layer == 0) {
    // The base strip beyond r stands for the tail: Marsaglia's (1964) tail sampler.
    double a, b;
    do {
      a = -std::log(1.0 - rare_.uniform()) / detail::BulkZigguratTables::kTailStart;
      b = -std::log(1.0 - rare_.uniform());
    } while (2.0 * b < a * a);
    return sign * (detail::BulkZigguratTables::kTailStart + a);
  }
  // The wedge between the layer's core and the curve: accepted under f, else the ziggurat starts
  // over, here with a whole deviate of the scalar stream (independent of everything before).
  const double x = static_cast<double>(draw >> kUShift) * z.unit_width[layer];
  const double y = z.height[layer] + rare_.uniform() * (z.height[layer + 1] - z.height[layer]);
  if (y < std::exp(-0.5 * x * x)) return sign * x;
  return rare_.normal();
}

// The reference: every other path gives these bits.
void BulkNormalStream::fill_scalar(std::size_t n, double scale, double* out) {
  const detail::BulkZigguratTables& z = detail::bulk_ziggurat_tables();
  std::size_t k = 0;
  while (k < n) {
    std::uint64_t bits[8];
    for (int g = 0; g < 8; ++g) {
      bits[g] = rotl64(state_[1][g] * 5, 7) * 9;
      const std::uint64_t t = state_[1][g] << 17;
      state_[2][g] ^= state_[0][g];
      state_[3][g] ^= state_[1][g];
      state_[1][g] ^= state_[2][g];
      state_[0][g] ^= state_[3][g];
      state_[2][g] ^= t;
      state_[3][g] = rotl64(state_[3][g], 45);
    }
    for (int d = 0; d < 16 && k < n; ++d, ++k) {
      const std::uint32_t draw = static_cast<std::uint32_t>(bits[d / 2] >> (32 * (d % 2)));
      const int layer = static_cast<int>(draw & kLayerBits);
      const double x = static_cast<double>(draw >> kUShift) * z.unit_width[layer];
      if (x < z.width[layer + 1]) {
        // The sign bit moved to the IEEE sign without a branch (one on it mispredicts half the time).
        std::uint64_t x_bits;
        std::memcpy(&x_bits, &x, sizeof x_bits);
        x_bits ^= std::uint64_t(draw & kSignBit) << 55;
        double signed_x;
        std::memcpy(&signed_x, &x_bits, sizeof signed_x);
        out[k] = signed_x * scale;
      } else {
        out[k] = outside_core(draw) * scale;
        ++last_fill_outside_core_;
      }
    }
  }
}

void BulkNormalStream::fill(std::size_t n, double scale, double* out, Kernel kernel) {
  last_fill_outside_core_ = 0;
#if defined(__x86_64__) && defined(__GNUC__)
  if (kernel == Kernel::kFastest && cpu::has_avx512dq()) return fill_avx512(n, scale, out);
  if (kernel != Kernel::kScalar && cpu::has_avx2()) return fill_avx2(n, scale, out);
#else
  (void)kernel;
#endif
  fill_scalar(n, scale, out);
}

#if defined(__x86_64__) && defined(__GNUC__)
// The lanes make a chunk of draws (up to 256) without a branch: each draw's value were it inside
// its core, written in place, and the positions and draws of those that are not (compressed
// stores); then those few are filled in, in order. A fill's last step may make more draws than it
// needs: they go to a scratch row and are dropped, their rare ones unfilled, as fill_scalar drops
// them.
__attribute__((target("avx512f,avx512dq"))) void BulkNormalStream::fill_avx512(std::size_t n, double scale,
                                                                               double* out) {
  const detail::BulkZigguratTables& z = detail::bulk_ziggurat_tables();
  constexpr std::size_t kChunk = 256;
  alignas(64) double scratch[16];
  alignas(64) std::uint32_t outside_position[kChunk], outside_draw[kChunk];
  const __m512i layer_bits = _mm512_set1_epi32(int(kLayerBits)), sign_bit = _mm512_set1_epi32(int(kSignBit));
  const __m512i step_positions = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512d scales = _mm512_set1_pd(scale), negative_zero = _mm512_set1_pd(-0.0);
  __m512i s0 = _mm512_load_si512(state_[0]), s1 = _mm512_load_si512(state_[1]), s2 = _mm512_load_si512(state_[2]),
          s3 = _mm512_load_si512(state_[3]);
  for (std::size_t chunk_start = 0; chunk_start < n; chunk_start += kChunk) {
    const std::size_t chunk_end = std::min(n, chunk_start + kChunk);
    std::size_t outside_count = 0;
    for (std::size_t k = chunk_start; k < chunk_end; k += 16) {
      // xoshiro256** in each lane: result = rotl(s1 * 5, 7) * 9, then the state update.
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
      // As 16 x 32 bits, element d is generator d / 2's low (even d) or high (odd d) half.
      const __m512i layer = _mm512_and_si512(bits, layer_bits);
      const __m512i u = _mm512_srli_epi32(bits, kUShift);
      const __mmask16 negative = _mm512_test_epi32_mask(bits, sign_bit);
      __mmask16 outside = 0;
      double* row = k + 16 <= n ? out + k : scratch;
      for (int half = 0; half < 2; ++half) {
        const __m256i layer8 = half ? _mm512_extracti64x4_epi64(layer, 1) : _mm512_castsi512_si256(layer);
        const __m256i u8 = half ? _mm512_extracti64x4_epi64(u, 1) : _mm512_castsi512_si256(u);
        const __m512d x = _mm512_mul_pd(_mm512_cvtepu32_pd(u8), _mm512_i32gather_pd(layer8, z.unit_width, 8));
        const __m512d next_width = _mm512_i32gather_pd(layer8, z.width + 1, 8);
        outside |= __mmask16(_mm512_cmp_pd_mask(x, next_width, _CMP_NLT_UQ)) << (8 * half);
        const __m512d signed_x = _mm512_mask_xor_pd(x, __mmask8(negative >> (8 * half)), x, negative_zero);
        _mm512_storeu_pd(row + 8 * half, _mm512_mul_pd(signed_x, scales));
      }
      if (row == scratch) std::memcpy(out + k, scratch, sizeof(double) * (n - k));
      // Positions past n are dropped with the rest of the step.
      const std::size_t valid = std::min<std::size_t>(16, n - k);
      outside &= __mmask16((1u << valid) - 1u);
      const __m512i positions = _mm512_add_epi32(step_positions, _mm512_set1_epi32(int(k)));
      _mm512_mask_compressstoreu_epi32(outside_position + outside_count, outside, positions);
      _mm512_mask_compressstoreu_epi32(outside_draw + outside_count, outside, bits);
      outside_count += std::size_t(__builtin_popcount(outside));
    }
    for (std::size_t i = 0; i < outside_count; ++i) out[outside_position[i]] = outside_core(outside_draw[i]) * scale;
    last_fill_outside_core_ += outside_count;
  }
  _mm512_store_si512(state_[0], s0);
  _mm512_store_si512(state_[1], s1);
  _mm512_store_si512(state_[2], s2);
  _mm512_store_si512(state_[3], s3);
}

namespace {
__attribute__((target("avx2"))) inline __m256i rotl_avx2(__m256i x, int k) {
  return _mm256_or_si256(_mm256_slli_epi64(x, k), _mm256_srli_epi64(x, 64 - k));
}
}  // namespace

// fill_avx512 in two halves of four generators (AVX2 has no 64-bit rotate or compressed store).
__attribute__((target("avx2"))) void BulkNormalStream::fill_avx2(std::size_t n, double scale, double* out) {
  const detail::BulkZigguratTables& z = detail::bulk_ziggurat_tables();
  constexpr std::size_t kChunk = 256;
  alignas(32) double values[16];
  alignas(32) std::uint32_t draws[16];
  std::uint32_t outside_position[kChunk], outside_draw[kChunk];
  const __m256i layer_bits = _mm256_set1_epi32(int(kLayerBits)), sign_bit = _mm256_set1_epi32(int(kSignBit));
  const __m256d scales = _mm256_set1_pd(scale);
  __m256i s[2][4];
  for (int word = 0; word < 4; ++word)
    for (int part = 0; part < 2; ++part)
      s[part][word] = _mm256_load_si256(reinterpret_cast<const __m256i*>(state_[word] + 4 * part));
  for (std::size_t chunk_start = 0; chunk_start < n; chunk_start += kChunk) {
    const std::size_t chunk_end = std::min(n, chunk_start + kChunk);
    std::size_t outside_count = 0;
    for (std::size_t k = chunk_start; k < chunk_end; k += 16) {
      unsigned outside = 0;
      for (int part = 0; part < 2; ++part) {
        __m256i* st = s[part];
        const __m256i times5 = _mm256_add_epi64(st[1], _mm256_slli_epi64(st[1], 2));
        const __m256i rotated = rotl_avx2(times5, 7);
        const __m256i bits = _mm256_add_epi64(rotated, _mm256_slli_epi64(rotated, 3));
        const __m256i t = _mm256_slli_epi64(st[1], 17);
        st[2] = _mm256_xor_si256(st[2], st[0]);
        st[3] = _mm256_xor_si256(st[3], st[1]);
        st[1] = _mm256_xor_si256(st[1], st[2]);
        st[0] = _mm256_xor_si256(st[0], st[3]);
        st[2] = _mm256_xor_si256(st[2], t);
        st[3] = rotl_avx2(st[3], 45);
        _mm256_store_si256(reinterpret_cast<__m256i*>(draws + 8 * part), bits);
        const __m256i layer = _mm256_and_si256(bits, layer_bits);
        const __m256i u = _mm256_srli_epi32(bits, kUShift);
        // The sign bit moved to bit 31 of each 32-bit half, then widened to each double's bit 63.
        const __m256i sign32 = _mm256_slli_epi32(_mm256_and_si256(bits, sign_bit), 23);
        for (int quarter = 0; quarter < 2; ++quarter) {
          const __m128i layer4 = quarter ? _mm256_extracti128_si256(layer, 1) : _mm256_castsi256_si128(layer);
          const __m128i u4 = quarter ? _mm256_extracti128_si256(u, 1) : _mm256_castsi256_si128(u);
          const __m128i sign4 = quarter ? _mm256_extracti128_si256(sign32, 1) : _mm256_castsi256_si128(sign32);
          // u < 2^23: as a signed 32-bit integer it converts exactly.
          const __m256d x = _mm256_mul_pd(_mm256_cvtepi32_pd(u4), _mm256_i32gather_pd(z.unit_width, layer4, 8));
          const __m256d next_width = _mm256_i32gather_pd(z.width + 1, layer4, 8);
          outside |= unsigned(_mm256_movemask_pd(_mm256_cmp_pd(x, next_width, _CMP_NLT_UQ)))
                     << (8 * part + 4 * quarter);
          const __m256i sign64 = _mm256_slli_epi64(_mm256_cvtepu32_epi64(sign4), 32);
          const __m256d signed_x = _mm256_xor_pd(x, _mm256_castsi256_pd(sign64));
          _mm256_store_pd(values + 8 * part + 4 * quarter, _mm256_mul_pd(signed_x, scales));
        }
      }
      const std::size_t valid = std::min<std::size_t>(16, n - k);
      std::memcpy(out + k, values, sizeof(double) * valid);
      outside &= (1u << valid) - 1u;
      while (outside) {
        const int d = __builtin_ctz(outside);
        outside &= outside - 1;
        outside_position[outside_count] = std::uint32_t(k) + std::uint32_t(d);
        outside_draw[outside_count++] = draws[d];
      }
    }
    for (std::size_t i = 0; i < outside_count; ++i) out[outside_position[i]] = outside_core(outside_draw[i]) * scale;
    last_fill_outside_core_ += outside_count;
  }
  for (int word = 0; word < 4; ++word)
    for (int part = 0; part < 2; ++part)
      _mm256_store_si256(reinterpret_cast<__m256i*>(state_[word] + 4 * part), s[part][word]);
}
#endif

}  // namespace panoscan
