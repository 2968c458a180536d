#include "panoscan/eval/error_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "panoscan/core/error.h"

namespace panoscan::eval {

double percentile_of_sorted(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  // Type 7 (Hyndman & Fan 1996): h = (n - 1) q, interpolate between the neighbouring order statistics.
  const double h = (static_cast<double>(sorted.size()) - 1.0) * std::clamp(q, 0.0, 1.0);
  const std::size_t lower = static_cast<std::size_t>(std::floor(h));
  const std::size_t upper = std::min(lower + 1, sorted.size() - 1);
  const double fraction = h - static_cast<double>(lower);
  return sorted[lower] + fraction * (sorted[upper] - sorted[lower]);
}

ErrorStats summarize_errors(std::vector<double> values) {
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    stats.rmse = stats.mean = stats.median = stats.p90 = stats.p99 = stats.max = nan;
    return stats;
  }
  long double sum = 0.0L, sum_squares = 0.0L;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double v = values[i];
    if (!std::isfinite(v)) throw make_error("", "error " + std::to_string(i), "not a finite number");
    sum += v;
    sum_squares += static_cast<long double>(v) * v;
  }
  const long double n = static_cast<long double>(values.size());
  stats.mean = static_cast<double>(sum / n);
  stats.rmse = static_cast<double>(std::sqrt(sum_squares / n));
  std::sort(values.begin(), values.end());
  stats.median = percentile_of_sorted(values, 0.5);
  stats.p90 = percentile_of_sorted(values, 0.9);
  stats.p99 = percentile_of_sorted(values, 0.99);
  stats.max = values.back();
  return stats;
}

Histogram make_histogram(const std::vector<double>& values, double max, int bins) {
  Histogram histogram;
  if (!(max > 0) || bins <= 0) throw make_error("", "histogram", "needs a positive range and bin count");
  histogram.bin_width = max / bins;
  histogram.counts.assign(static_cast<std::size_t>(bins), 0);
  for (double v : values) {
    if (!(v < max)) {
      ++histogram.overflow;
      continue;
    }
    const int bin = std::clamp(static_cast<int>(std::floor(v / histogram.bin_width)), 0, bins - 1);
    ++histogram.counts[static_cast<std::size_t>(bin)];
  }
  return histogram;
}

}  // namespace panoscan::eval
