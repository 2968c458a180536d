// smallest_keys: both kernels choose exactly the k smallest keys, reported by ascending position.
// (kFastest is the AVX-512 quickselect on CPUs that have it, std::nth_element elsewhere.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "panoscan/core/smallest_keys.h"

namespace panoscan {
namespace {

// The positions of the k smallest by a full sort: the reference.
std::vector<std::uint32_t> sorted_reference(const std::vector<std::uint64_t>& keys, std::size_t k) {
  std::vector<std::uint32_t> order(keys.size());
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  order.resize(std::min(k, keys.size()));
  std::sort(order.begin(), order.end());
  return order;
}

std::vector<std::uint32_t> run(const std::vector<std::uint64_t>& keys, std::size_t k, SmallestKeysKernel kernel) {
  std::vector<std::uint32_t> positions(keys.size() + 1, 0xFFFFFFFFu);
  std::vector<std::uint64_t> scratch;
  const std::size_t n = smallest_keys(keys.data(), keys.size(), k, positions.data(), scratch, kernel);
  positions.resize(n);
  return positions;
}

// Distinct keys of the given kind: spread over the whole range (the top bit set too, which a signed
// compare would misorder), or crowded into a few values apart in their low bits only (4096 of them).
std::vector<std::uint64_t> distinct_keys(std::mt19937_64& rng, std::size_t count, bool crowded) {
  std::vector<std::uint64_t> keys;
  while (keys.size() < count) {
    const std::uint64_t key = crowded ? (std::uint64_t(rng() % 4) << 62) | (rng() % 1024) : rng();
    if (std::find(keys.begin(), keys.end(), key) == keys.end()) keys.push_back(key);
  }
  return keys;
}

TEST(SmallestKeys, BothKernelsChooseTheKSmallestInPositionOrder) {
  std::mt19937_64 rng(20261206);
  for (const bool crowded : {false, true})
    for (std::size_t count : {1, 2, 3, 7, 8, 9, 15, 16, 17, 31, 48, 49, 63, 64, 65, 100, 1089}) {
      const std::vector<std::uint64_t> keys = distinct_keys(rng, count, crowded);
      for (std::size_t k : {std::size_t(0), std::size_t(1), count / 3, count / 2, count - 1, count, count + 5}) {
        const std::vector<std::uint32_t> expected = sorted_reference(keys, k);
        EXPECT_EQ(run(keys, k, SmallestKeysKernel::kFastest), expected) << count << " keys, k " << k;
        EXPECT_EQ(run(keys, k, SmallestKeysKernel::kNthElement), expected) << count << " keys, k " << k;
      }
    }
}

// Sorted and reversed inputs are quickselect's classic worst cases for a poor pivot.
TEST(SmallestKeys, OrderedInputs) {
  for (const bool ascending : {true, false})
    for (std::size_t count : {49, 64}) {
      std::vector<std::uint64_t> keys(count);
      for (std::size_t i = 0; i < count; ++i) keys[i] = ascending ? i * 3 : (count - i) * 3;
      for (std::size_t k = 1; k <= count; ++k) {
        const std::vector<std::uint32_t> expected = sorted_reference(keys, k);
        EXPECT_EQ(run(keys, k, SmallestKeysKernel::kFastest), expected) << count << " keys, k " << k;
        EXPECT_EQ(run(keys, k, SmallestKeysKernel::kNthElement), expected) << count << " keys, k " << k;
      }
    }
}

}  // namespace
}  // namespace panoscan
