// The shared ORB module (recon/features): the matching rule every user gets, and detection.
#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "panoscan/recon/orb_features.h"

namespace panoscan {
namespace {

OrbDescriptor random_descriptor(std::mt19937& rng) {
  OrbDescriptor d;
  for (auto& byte : d) byte = std::uint8_t(rng() & 0xff);
  return d;
}

// `bits` bits of d flipped.
OrbDescriptor flipped(OrbDescriptor d, int bits) {
  for (int i = 0; i < bits; ++i) d[std::size_t(i % 32)] ^= std::uint8_t(1u << (i / 32));
  return d;
}

TEST(OrbMatching, RatioTestAndOneAPerB) {
  std::mt19937 rng(3);
  std::vector<OrbDescriptor> a, b;
  // a0 -> b0: a clear match.
  b.push_back(random_descriptor(rng));
  a.push_back(flipped(b[0], 4));
  // a1 is ambiguous between b1 and b2 (ratio fails on a's side).
  b.push_back(random_descriptor(rng));
  b.push_back(flipped(b[1], 2));
  a.push_back(flipped(b[1], 1));
  // a2 and a3 both choose b3: only the closer, a3, keeps it.
  b.push_back(random_descriptor(rng));
  a.push_back(flipped(b[3], 5));
  a.push_back(flipped(b[3], 3));
  // a4 -> b4 but farther than max_hamming.
  b.push_back(random_descriptor(rng));
  a.push_back(flipped(b[4], 70));
  const auto matches = match_orb(a, b, OrbMatchOptions{});
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0], std::make_pair(0, 0));
  EXPECT_EQ(matches[1], std::make_pair(3, 3));
  // Subsets: indices refer to the full vectors.
  const auto restricted = match_orb(a, {0, 4}, b, {0, 4}, OrbMatchOptions{});
  ASSERT_EQ(restricted.size(), 1u);
  EXPECT_EQ(restricted[0], std::make_pair(0, 0));
  EXPECT_EQ(hamming_distance(a[0], b[0]), 4);
  OrbMatchOptions loose;
  loose.max_hamming = 256;
  EXPECT_EQ(match_orb({a[4]}, {b[4]}, loose).size(), 1u);
}

TEST(OrbMatching, AmongCandidatesAppliesTheSameRuleWithinEachList) {
  std::mt19937 rng(5);
  std::vector<OrbDescriptor> a, b;
  for (int i = 0; i < 40; ++i) b.push_back(random_descriptor(rng));
  for (int i = 0; i < 40; ++i) a.push_back(flipped(b[std::size_t(i)], 3 + i % 7));
  // Every b as every a's candidate: the brute-force matcher's result, order included.
  std::vector<int> offsets{0}, all;
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (int j = 0; j < int(b.size()); ++j) all.push_back(j);
    offsets.push_back(int(all.size()));
  }
  EXPECT_EQ(match_orb_among(a, b, offsets, all, OrbMatchOptions{}), match_orb(a, b, OrbMatchOptions{}));

  // Windows: a0's list lacks its twin b0 (no match: the others are far); a1 sees b1 and a near
  // copy of it (the ratio test fails within the list); a2 and a3 both see only b2 (the closer one, a2, keeps it);
  // a4's list is empty.
  OrbDescriptor near_b1 = b[1];
  near_b1[10] ^= 0x08;  // 5 bits from a1 against b1's 4: 4 < 0.8 x 5 fails
  b.push_back(near_b1);
  const int copy_of_b1 = int(b.size()) - 1;
  std::vector<std::vector<int>> lists = {{5, 6}, {1, copy_of_b1}, {2}, {2}, {}};
  a[3] = flipped(b[2], 9);
  std::vector<int> window_offsets{0}, windows;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (i < lists.size()) windows.insert(windows.end(), lists[i].begin(), lists[i].end());
    window_offsets.push_back(int(windows.size()));
  }
  std::vector<OrbDescriptor> first_five(a.begin(), a.begin() + 5);
  window_offsets.resize(6);
  const auto matches = match_orb_among(first_five, b, window_offsets, windows, OrbMatchOptions{});
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0], std::make_pair(2, 2));
  EXPECT_THROW(match_orb_among(a, b, {0, 0}, {}, OrbMatchOptions{}), std::invalid_argument);
}

TEST(OrbDetection, KeypointsKeepTheirDistanceFromTheBorder) {
  ImageU8 image(200, 150, 1);
  std::mt19937 rng(5);
  for (auto& p : image.data) p = std::uint8_t(rng() % 256);
  OrbDetectorOptions options;
  options.features = 300;
  options.patch_px = 15;
  options.border_px = 20;
  std::vector<OrbKeypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  detect_orb(image, options, &keypoints, &descriptors);
  ASSERT_GT(keypoints.size(), 50u);
  EXPECT_EQ(keypoints.size(), descriptors.size());
  for (const OrbKeypoint& k : keypoints) {
    EXPECT_GE(k.u, 19.0f);
    EXPECT_GE(k.v, 19.0f);
    EXPECT_LE(k.u, 200 - 20.0f);
    EXPECT_LE(k.v, 150 - 20.0f);
  }
}

}  // namespace
}  // namespace panoscan
