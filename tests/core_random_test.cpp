#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

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

// The bulk stream's kernels against the scalar reference: the same bits for fills that are not a
// whole number of steps (the last step's extra draws dropped, rare ones among them unfilled), and
// every stream left where the reference leaves it (a second fill agrees too). 2003 draws hold about
// 30 outside their core, so the wedge and the tail are in every comparison.
TEST(BulkNormals, EveryKernelGivesTheScalarReferencesBits) {
  using Kernel = BulkNormalStream::Kernel;
  for (const std::size_t n : {std::size_t(1), std::size_t(15), std::size_t(16), std::size_t(17), std::size_t(640),
                              std::size_t(1280), std::size_t(2003)})
    for (std::int64_t row = 0; row < 3; ++row) {
      const double scale = 0.37;
      std::vector<std::vector<double>> drawn;
      std::size_t outside_core = 0;
      for (const Kernel kernel : {Kernel::kScalar, Kernel::kAvx2, Kernel::kFastest}) {
        BulkNormalStream stream(5, 1, 9, RandomPurpose::kDepthShift, row);
        std::vector<double> out(2 * n);
        stream.fill(n, scale, out.data(), kernel);
        outside_core += stream.last_fill_outside_core();
        stream.fill(n, scale, out.data() + n, kernel);
        drawn.push_back(out);
      }
      for (std::size_t k = 1; k < drawn.size(); ++k)
        for (std::size_t i = 0; i < 2 * n; ++i)
          ASSERT_EQ(drawn[k][i], drawn[0][i]) << "kernel " << k << ", n " << n << ", row " << row << ", draw " << i;
      if (n == 2003) {
        EXPECT_GT(outside_core, 0u);
      }
    }
}

TEST(BulkNormals, EveryKeyPartChangesTheSequence) {
  auto first = [](std::uint64_t seed, std::int64_t camera, std::int64_t frame, RandomPurpose purpose,
                  std::int64_t lane) {
    double value;
    BulkNormalStream(seed, camera, frame, purpose, lane).fill(1, 1.0, &value);
    return value;
  };
  std::set<double> seen{first(7, 1, 2, RandomPurpose::kDepthShift, 3)};
  EXPECT_EQ(first(7, 1, 2, RandomPurpose::kDepthShift, 3), *seen.begin());
  seen.insert(first(8, 1, 2, RandomPurpose::kDepthShift, 3));
  seen.insert(first(7, 2, 2, RandomPurpose::kDepthShift, 3));
  seen.insert(first(7, 1, 3, RandomPurpose::kDepthShift, 3));
  seen.insert(first(7, 1, 2, RandomPurpose::kDepthDisparity, 3));
  seen.insert(first(7, 1, 2, RandomPurpose::kDepthShift, 4));
  EXPECT_EQ(seen.size(), 6u);
}

// The exact normal probabilities of 64 bins over [-4, 4] and the two tails against 4 million bulk
// deviates (one fill per 640-pixel row, as the simulator draws them): a chi-square over 66 bins,
// which a wedge accepted without its test or a tail cut at r fails by far. Also the share of draws
// outside their layer's core (the 256-layer ziggurat's 1.49%) and the correlation of neighbouring
// draws (lag 1: the two halves of one 64-bit draw; lag 2 and 16: neighbouring generators and steps).
TEST(BulkNormals, HaveTheGaussianShapeIncludingTheTailsAndNoCorrelation) {
  constexpr int kBins = 64, kRows = 3125;
  constexpr std::size_t kPerRow = 1280;
  const double n = double(kRows) * kPerRow;
  std::vector<double> count(kBins + 2, 0.0);
  std::vector<double> row(kPerRow);
  double outside = 0, lag1 = 0, lag2 = 0, lag16 = 0, sum2 = 0;
  for (int r = 0; r < kRows; ++r) {
    BulkNormalStream stream(11, 0, r / 480, RandomPurpose::kDepthShift, r % 480);
    stream.fill(kPerRow, 1.0, row.data());
    outside += double(stream.last_fill_outside_core());
    for (std::size_t i = 0; i < kPerRow; ++i) {
      const double x = row[i];
      const int bin = x < -4 ? 0 : x >= 4 ? kBins + 1 : 1 + std::min(kBins - 1, int((x + 4) / 8 * kBins));
      count[bin] += 1;
      sum2 += x * x;
      if (i >= 1) lag1 += x * row[i - 1];
      if (i >= 2) lag2 += x * row[i - 2];
      if (i >= 16) lag16 += x * row[i - 16];
    }
  }
  const auto cdf = [](double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); };
  double chi2 = 0;
  for (int bin = 0; bin < kBins + 2; ++bin) {
    const double lo = bin == 0 ? -INFINITY : -4 + 8.0 * (bin - 1) / kBins;
    const double hi = bin == kBins + 1 ? INFINITY : -4 + 8.0 * bin / kBins;
    const double expected = n * (cdf(hi) - cdf(lo));
    chi2 += (count[bin] - expected) * (count[bin] - expected) / expected;
  }
  // 65 degrees of freedom: the 99.999% point is about 124.
  EXPECT_LT(chi2, 124.0);
  EXPECT_NEAR((count[0] + count[kBins + 1]) / n, 6.334e-5, 1.5e-5);  // beyond 4 sigma: the tail
  EXPECT_NEAR(sum2 / n, 1.0, 0.004);
  EXPECT_NEAR(outside / n, 0.01492, 0.0008);
  for (const double lag : {lag1, lag2, lag16}) EXPECT_LT(std::abs(lag / n), 0.003);
}
