#include <cmath>
#include <set>

#include <gtest/gtest.h>

#include "panoscan/core/random.h"

using namespace panoscan;

TEST(Random, SameKeySameSequence) {
  RandomStream a(7, 1, 2, RandomPurpose::kDepthShift, 3), b(7, 1, 2, RandomPurpose::kDepthShift, 3);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(a.next_u64(), b.next_u64());
}

TEST(Random, EveryKeyPartChangesTheSequence) {
  const std::uint64_t base = RandomStream(7, 1, 2, RandomPurpose::kDepthShift, 3).next_u64();
  std::set<std::uint64_t> seen{base};
  seen.insert(RandomStream(8, 1, 2, RandomPurpose::kDepthShift, 3).next_u64());
  seen.insert(RandomStream(7, 2, 2, RandomPurpose::kDepthShift, 3).next_u64());
  seen.insert(RandomStream(7, 1, 3, RandomPurpose::kDepthShift, 3).next_u64());
  seen.insert(RandomStream(7, 1, 2, RandomPurpose::kDepthDisparity, 3).next_u64());
  seen.insert(RandomStream(7, 1, 2, RandomPurpose::kDepthShift, 4).next_u64());
  EXPECT_EQ(seen.size(), 6u);
}

TEST(Random, NormalHasTheGaussianShapeIncludingTheTails) {
  // CDF at a few points and the tail masses, which a sampler with a wrong wedge or tail misses.
  RandomStream rng(3, 0, 0, RandomPurpose::kGeneric);
  const int n = 1000000;
  int below[5] = {0, 0, 0, 0, 0};
  const double points[5] = {-2.0, -1.0, 0.0, 0.5, 1.5};
  int beyond2 = 0, beyond3 = 0, beyond4 = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    for (int k = 0; k < 5; ++k) below[k] += x < points[k];
    beyond2 += std::abs(x) > 2;
    beyond3 += std::abs(x) > 3;
    beyond4 += std::abs(x) > 4;
  }
  const double cdf[5] = {0.0227501, 0.1586553, 0.5, 0.6914625, 0.9331928};
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(double(below[k]) / n, cdf[k], 0.0015) << "at " << points[k];
  EXPECT_NEAR(double(beyond2) / n, 0.0455003, 0.0008);
  EXPECT_NEAR(double(beyond3) / n, 0.0026998, 0.0002);
  EXPECT_NEAR(double(beyond4) / n, 6.334e-5, 3e-5);
}

TEST(Random, UniformAndNormalMoments) {
  RandomStream rng(42, 0, 0, RandomPurpose::kGeneric);
  const int n = 200000;
  double sum = 0, sum2 = 0, usum = 0;
  double umin = 1, umax = 0;
  for (int i = 0; i < n; ++i) {
    const double x = rng.normal();
    sum += x;
    sum2 += x * x;
    const double u = rng.uniform();
    usum += u;
    umin = std::min(umin, u);
    umax = std::max(umax, u);
  }
  EXPECT_NEAR(sum / n, 0.0, 0.01);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.01);
  EXPECT_NEAR(usum / n, 0.5, 0.005);
  EXPECT_GE(umin, 0.0);
  EXPECT_LT(umax, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const int k = rng.uniform_int(-3, 5);
    ASSERT_GE(k, -3);
    ASSERT_LE(k, 5);
  }
}

// draw_normals (eight streams per AVX-512 operation where the CPU has it) against normal() called
// stream by stream: the same values, and every stream left where the calls leave it. 11 streams (a
// lane block and three scalar ones) and 2003 draws (not a whole number of 8): about 190 draws take
// the ziggurat's wedge or tail, which draw further values from their stream in the middle of a row.
TEST(Random, DrawNormalsIsBitIdenticalToNormalCalls) {
  const std::size_t count = 11, n = 2003;
  const double scale = 0.37;
  std::vector<RandomStream> bulk, single;
  for (std::size_t s = 0; s < count; ++s) {
    bulk.emplace_back(5, 1, 9, RandomPurpose::kDepthShift, std::int64_t(s));
    single.emplace_back(5, 1, 9, RandomPurpose::kDepthShift, std::int64_t(s));
  }
  std::vector<std::vector<double>> drawn(count, std::vector<double>(n));
  std::vector<double*> out;
  for (auto& row : drawn) out.push_back(row.data());
  draw_normals(bulk.data(), count, n, scale, out.data());
  std::size_t outside_core = 0;
  for (std::size_t s = 0; s < count; ++s) {
    for (std::size_t i = 0; i < n; ++i) {
      const double expected = single[s].normal() * scale;
      ASSERT_EQ(drawn[s][i], expected) << "stream " << s << " draw " << i;
      outside_core += std::abs(expected / scale) > 3.0;
    }
    EXPECT_EQ(bulk[s].next_u64(), single[s].next_u64()) << "stream " << s << " left elsewhere";
  }
  EXPECT_GT(outside_core, 0u);  // draws beyond 3 sigma: the tail path was taken
}
