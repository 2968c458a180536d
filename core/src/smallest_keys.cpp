#include "panoscan/core/smallest_keys.h"

#include <algorithm>

#include "panoscan/core/cpu_features.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define PANOSCAN_SMALLEST_KEYS_AVX512 1
#endif

namespace panoscan {

namespace {

#ifdef PANOSCAN_SMALLEST_KEYS_AVX512
// The k smallest of the in-play keys (at most 64) by quickselect, with the keys held in registers
// and the keys still in play as a bit mask: each round counts those below a pivot with one compare
// per 8 slots and keeps the side that holds the k-th. A handful of rounds and one unpredictable
// branch each, where std::nth_element mispredicts about every other comparison. Slots out of play
// are never loaded. V vectors cover every in-play slot.
template <int V>
__attribute__((target("avx512f,bmi2"))) std::uint64_t smallest_mask_avx512(const std::uint64_t* keys,
                                                                           std::uint64_t in_play, std::size_t k) {
  __m512i key[V];
  for (int v = 0; v < V; ++v) key[v] = _mm512_maskz_loadu_epi64(__mmask8(in_play >> (8 * v)), keys + 8 * v);
  std::uint64_t chosen = 0;  // keys known to be among the k smallest
  std::size_t still_needed = k;
  for (;;) {
    // Median of three in-play keys (first, middle and last by slot) as the pivot.
    const int m = __builtin_popcountll(in_play);
    const std::uint64_t a = keys[__builtin_ctzll(in_play)];
    const std::uint64_t b = keys[__builtin_ctzll(_pdep_u64(std::uint64_t(1) << (m / 2), in_play))];
    const std::uint64_t c = keys[63 - __builtin_clzll(in_play)];
    const std::uint64_t pivot = std::max(std::min(a, b), std::min(std::max(a, b), c));
    const __m512i pivots = _mm512_set1_epi64(static_cast<long long>(pivot));
    std::uint64_t below = 0, at = 0;
    for (int v = 0; v < V; ++v) {
      below |= std::uint64_t(_mm512_cmplt_epu64_mask(key[v], pivots)) << (8 * v);
      at |= std::uint64_t(_mm512_cmpeq_epu64_mask(key[v], pivots)) << (8 * v);
    }
    below &= in_play;
    at &= in_play;
    // Every round removes at least the pivot from play, so this ends.
    const std::size_t smaller = std::size_t(__builtin_popcountll(below));
    if (smaller >= still_needed) {
      if (smaller == still_needed) return chosen | below;
      in_play = below;
    } else {
      chosen |= below | at;
      still_needed -= smaller + 1;
      if (still_needed == 0) return chosen;
      in_play &= ~(below | at);
    }
  }
}

std::uint64_t smallest_mask_avx512(const std::uint64_t* keys, std::uint64_t in_play, std::size_t k) {
  switch ((63 - __builtin_clzll(in_play)) / 8 + 1) {
    case 1: return smallest_mask_avx512<1>(keys, in_play, k);
    case 2: return smallest_mask_avx512<2>(keys, in_play, k);
    case 3: return smallest_mask_avx512<3>(keys, in_play, k);
    case 4: return smallest_mask_avx512<4>(keys, in_play, k);
    case 5: return smallest_mask_avx512<5>(keys, in_play, k);
    case 6: return smallest_mask_avx512<6>(keys, in_play, k);
    case 7: return smallest_mask_avx512<7>(keys, in_play, k);
    default: return smallest_mask_avx512<8>(keys, in_play, k);
  }
}

bool vector_kernel(SmallestKeysKernel kernel) {
  return kernel == SmallestKeysKernel::kFastest && cpu::has_avx512dq() && cpu::has_bmi2();
}
#endif

// The k-th smallest (k >= 1) of keys[0..n), which it reorders: the scalar kernel's threshold (the
// chosen keys are those at or below it).
std::uint64_t kth_smallest(std::uint64_t* keys, std::size_t n, std::size_t k) {
  std::nth_element(keys, keys + k - 1, keys + n);
  return keys[k - 1];
}

}  // namespace

std::uint64_t smallest_keys_mask(const std::uint64_t* keys, std::uint64_t in_play, std::size_t k,
                                 SmallestKeysKernel kernel) {
  const std::size_t count = std::size_t(__builtin_popcountll(in_play));
  if (k >= count) return in_play;
  if (k == 0) return 0;
#ifdef PANOSCAN_SMALLEST_KEYS_AVX512
  if (vector_kernel(kernel)) return smallest_mask_avx512(keys, in_play, k);
#endif
  std::uint64_t in_play_keys[64];
  std::size_t n = 0;
  for (std::uint64_t rest = in_play; rest != 0; rest &= rest - 1) in_play_keys[n++] = keys[__builtin_ctzll(rest)];
  const std::uint64_t kth = kth_smallest(in_play_keys, n, k);
  std::uint64_t chosen = 0;
  for (std::uint64_t rest = in_play; rest != 0; rest &= rest - 1) {
    const int slot = __builtin_ctzll(rest);
    if (keys[slot] <= kth) chosen |= std::uint64_t(1) << slot;
  }
  return chosen;
}

std::size_t smallest_keys(const std::uint64_t* keys, std::size_t count, std::size_t k, std::uint32_t* positions,
                          std::vector<std::uint64_t>& scratch, SmallestKeysKernel kernel) {
  if (k >= count) {
    for (std::size_t i = 0; i < count; ++i) positions[i] = std::uint32_t(i);
    return count;
  }
  if (k == 0) return 0;
  if (count <= 64) {
    std::uint64_t chosen =
        smallest_keys_mask(keys, count == 64 ? ~std::uint64_t(0) : (std::uint64_t(1) << count) - 1, k, kernel);
    std::size_t n = 0;
    for (; chosen != 0; chosen &= chosen - 1) positions[n++] = std::uint32_t(__builtin_ctzll(chosen));
    return n;
  }
  scratch.assign(keys, keys + count);
  const std::uint64_t kth = kth_smallest(scratch.data(), count, k);
  std::size_t n = 0;
  for (std::size_t i = 0; i < count && n < k; ++i)
    if (keys[i] <= kth) positions[n++] = std::uint32_t(i);
  return n;
}

}  // namespace panoscan
