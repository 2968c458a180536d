// Summary statistics of a set of non-negative errors (distances, ATE, RPE...): the figures every
// table of the paper reports (RMSE) and the ones that show the shape of the distribution.
#pragma once

#include <cstddef>
#include <vector>

namespace panoscan::eval {

// All figures in the unit of the input. For an empty input, count is 0 and every figure is NaN
// (never a silent 0).
struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;  // sqrt(mean(e^2)), over all values
  double mean = 0.0;
  double median = 0.0;
  double p90 = 0.0;  // percentiles by linear interpolation between order statistics
  double p99 = 0.0;  // (numpy's default, "type 7")
  double max = 0.0;
};

// Throws Error if a value is not finite. Sums are accumulated serially in long double, so the
// result does not depend on the thread count.
ErrorStats summarize_errors(std::vector<double> values);

// q in [0, 1] of an ascending-sorted, non-empty vector (type-7 interpolation).
double percentile_of_sorted(const std::vector<double>& sorted, double q);

// Counts of values in [0, max) in equal bins, plus the values at or beyond max (for plots).
struct Histogram {
  double bin_width = 0.0;
  std::vector<std::size_t> counts;
  std::size_t overflow = 0;
};
Histogram make_histogram(const std::vector<double>& values, double max, int bins);

}  // namespace panoscan::eval
