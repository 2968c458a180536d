// Statistics over independent runs (seeds, rooms): the mean with a Student-t confidence interval,
// and paired comparisons of two methods measured on the same runs. What every multi-seed table
// reports (docs/ARCHITECTURE.md §14.3).
#pragma once

#include <vector>

namespace panoscan::eval {

// The Student-t distribution with `dof` degrees of freedom (dof >= 1): its CDF, computed through
// the regularised incomplete beta function (continued fraction), and its quantile (the inverse,
// by bisection to 1e-12). Throws Error for dof < 1 or p outside (0, 1).
double student_t_cdf(double t, int dof);
double student_t_quantile(double p, int dof);

// The mean of n independent values with its two-sided confidence interval
// mean ± t_{(1+c)/2, n-1} · sd / sqrt(n), sd the sample standard deviation (n - 1 in the
// denominator). n = 1 gives the value with a NaN interval and sd (one run says nothing about its
// spread); n = 0 gives NaN everywhere. Non-finite values are not allowed (Error): callers drop
// the runs that did not measure, and report n.
struct SampleSummary {
  int n = 0;
  double mean = 0.0;
  double sd = 0.0;
  double ci_low = 0.0, ci_high = 0.0;
  double half_width() const { return 0.5 * (ci_high - ci_low); }
};
SampleSummary summarize_sample(const std::vector<double>& values, double confidence = 0.95);

// A claim "A is better than B" tested on paired values (a[i], b[i] measured on the same run).
// The differences are oriented so that positive means the claim holds: b - a when lower is
// better, a - b otherwise. `holds` counts the runs with a positive difference; the verdict is
// "holds" when the whole interval is above 0, "reversed" when it is below, "within noise"
// otherwise (also for n < 2).
struct PairedComparison {
  SampleSummary difference;
  int holds = 0;
  int n = 0;
  const char* verdict = "within noise";
};
PairedComparison compare_paired(const std::vector<double>& a, const std::vector<double>& b, bool lower_is_better,
                                double confidence = 0.95);

}  // namespace panoscan::eval
