// Student-t quantiles against published values, the confidence interval of a known sample, and
// the verdicts of paired comparisons.
#include <cmath>

#include <gtest/gtest.h>

#include "panoscan/core/error.h"
#include "panoscan/eval/statistics.h"

namespace panoscan::eval {
namespace {

TEST(Statistics, StudentTQuantilesMatchTheTables) {
  // Two-sided 95% critical values (e.g. NIST/SEMATECH e-Handbook, Table of t).
  EXPECT_NEAR(student_t_quantile(0.975, 1), 12.7062047, 1e-6);
  EXPECT_NEAR(student_t_quantile(0.975, 2), 4.30265273, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 7), 2.36462425, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 30), 2.04227246, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.975, 1000), 1.96233908, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.995, 15), 2.94671288, 1e-7);
  EXPECT_NEAR(student_t_quantile(0.025, 7), -2.36462425, 1e-7);
  EXPECT_DOUBLE_EQ(student_t_cdf(0.0, 5), 0.5);
  // dof = 1 is the Cauchy distribution: CDF(t) = 1/2 + atan(t) / pi.
  EXPECT_NEAR(student_t_cdf(3.0, 1), 0.5 + std::atan(3.0) / M_PI, 1e-12);
  EXPECT_THROW(student_t_quantile(0.975, 0), Error);
  EXPECT_THROW(student_t_quantile(1.0, 3), Error);
}

TEST(Statistics, MeanAndIntervalOfASample) {
  const SampleSummary s = summarize_sample({1, 2, 3, 4});
  EXPECT_EQ(s.n, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_NEAR(s.sd, std::sqrt(5.0 / 3.0), 1e-12);
  const double half = 3.18244631 * std::sqrt(5.0 / 3.0) / 2.0;
  EXPECT_NEAR(s.ci_low, 2.5 - half, 1e-6);
  EXPECT_NEAR(s.ci_high, 2.5 + half, 1e-6);

  const SampleSummary one = summarize_sample({7});
  EXPECT_EQ(one.n, 1);
  EXPECT_EQ(one.mean, 7);
  EXPECT_TRUE(std::isnan(one.ci_low) && std::isnan(one.sd));
  EXPECT_TRUE(std::isnan(summarize_sample({}).mean));
  EXPECT_THROW(summarize_sample({1, NAN}), Error);
}

TEST(Statistics, PairedComparisonVerdicts) {
  // A lower than B on every run by about 1: holds.
  const PairedComparison holds = compare_paired({1.0, 2.1, 2.9, 4.0}, {2.0, 3.0, 4.1, 5.0}, true);
  EXPECT_EQ(holds.n, 4);
  EXPECT_EQ(holds.holds, 4);
  EXPECT_STREQ(holds.verdict, "holds");
  EXPECT_NEAR(holds.difference.mean, 1.025, 1e-12);
  // The same values read as "higher is better": reversed.
  EXPECT_STREQ(compare_paired({1.0, 2.1, 2.9, 4.0}, {2.0, 3.0, 4.1, 5.0}, false).verdict, "reversed");
  // Differences of both signs: within noise, with the count of runs where it holds.
  const PairedComparison noise = compare_paired({1, 3, 2, 5}, {2, 2, 3, 4}, true);
  EXPECT_EQ(noise.holds, 2);
  EXPECT_STREQ(noise.verdict, "within noise");
  // One run cannot decide.
  EXPECT_STREQ(compare_paired({1}, {5}, true).verdict, "within noise");
  EXPECT_THROW(compare_paired({1, 2}, {1}, true), Error);
}

}  // namespace
}  // namespace panoscan::eval
