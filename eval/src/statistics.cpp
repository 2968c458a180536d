// Student-t intervals and paired comparisons over independent runs; see statistics.h.
#include "panoscan/eval/statistics.h"

#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "panoscan/core/error.h"

namespace panoscan::eval {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The continued fraction of the regularised incomplete beta function I_x(a, b), evaluated by the
// modified Lentz method; converges quickly for x < (a + 1) / (a + b + 2).
double incomplete_beta_fraction(double a, double b, double x) {
  constexpr double kTiny = 1e-300;
  constexpr double kEpsilon = 1e-15;
  double c = 1.0;
  double d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::abs(d) < kTiny) d = kTiny;
  d = 1.0 / d;
  double fraction = d;
  for (int m = 1; m <= 10000; ++m) {
    // The even step d_{2m} = m (b - m) x / ((a + 2m - 1)(a + 2m)), then the odd step
    // d_{2m+1} = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
    for (int odd = 0; odd < 2; ++odd) {
      const double coefficient = odd == 0 ? m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m))
                                          : -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
      d = 1.0 + coefficient * d;
      if (std::abs(d) < kTiny) d = kTiny;
      c = 1.0 + coefficient / c;
      if (std::abs(c) < kTiny) c = kTiny;
      d = 1.0 / d;
      const double step = c * d;
      fraction *= step;
      if (odd == 1 && std::abs(step - 1.0) < kEpsilon) return fraction;
    }
  }
  return fraction;  // not reached for the arguments used here (a = dof / 2, b = 1 / 2)
}

double regularized_incomplete_beta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double log_front = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(log_front) * incomplete_beta_fraction(a, b, x) / a;
  // The symmetry I_x(a, b) = 1 - I_{1-x}(b, a) keeps the fraction in its fast range.
  return 1.0 - std::exp(log_front) * incomplete_beta_fraction(b, a, 1.0 - x) / b;
}

void check_dof(int dof) {
  if (dof < 1) throw make_error("statistics", "degrees of freedom", fmt::format("must be at least 1, got {}", dof));
}

}  // namespace

double student_t_cdf(double t, int dof) {
  check_dof(dof);
  if (std::isnan(t)) return kNaN;
  const double x = dof / (dof + t * t);
  const double tail = 0.5 * regularized_incomplete_beta(0.5 * dof, 0.5, x);  // P(T > |t|)
  return t > 0 ? 1.0 - tail : tail;
}

double student_t_quantile(double p, int dof) {
  check_dof(dof);
  if (!(p > 0.0 && p < 1.0)) throw make_error("statistics", "probability", fmt::format("must be in (0, 1), got {}", p));
  if (p < 0.5) return -student_t_quantile(1.0 - p, dof);
  // Bracket, then bisect: the CDF is monotone, and 60 halvings of a bracket below 2^20 reach 1e-12.
  double low = 0.0, high = 1.0;
  while (student_t_cdf(high, dof) < p && high < 1e12) high *= 2.0;
  for (int i = 0; i < 200 && high - low > 1e-12 * std::max(1.0, high); ++i) {
    const double mid = 0.5 * (low + high);
    (student_t_cdf(mid, dof) < p ? low : high) = mid;
  }
  return 0.5 * (low + high);
}

SampleSummary summarize_sample(const std::vector<double>& values, double confidence) {
  if (!(confidence > 0.0 && confidence < 1.0))
    throw make_error("statistics", "confidence", fmt::format("must be in (0, 1), got {}", confidence));
  SampleSummary s;
  s.n = int(values.size());
  if (s.n == 0) {
    s.mean = s.sd = s.ci_low = s.ci_high = kNaN;
    return s;
  }
  // Serial sums in long double: the result does not depend on how the runs were scheduled.
  long double sum = 0;
  for (double v : values) {
    if (!std::isfinite(v)) throw make_error("statistics", "value", "a value is not finite");
    sum += v;
  }
  s.mean = double(sum / s.n);
  if (s.n == 1) {
    s.sd = s.ci_low = s.ci_high = kNaN;
    return s;
  }
  long double squares = 0;
  for (double v : values) squares += (v - s.mean) * (v - s.mean);
  s.sd = std::sqrt(double(squares / (s.n - 1)));
  const double half = student_t_quantile(0.5 * (1.0 + confidence), s.n - 1) * s.sd / std::sqrt(double(s.n));
  s.ci_low = s.mean - half;
  s.ci_high = s.mean + half;
  return s;
}

PairedComparison compare_paired(const std::vector<double>& a, const std::vector<double>& b, bool lower_is_better,
                                double confidence) {
  if (a.size() != b.size())
    throw make_error("statistics", "paired values", fmt::format("{} against {} values", a.size(), b.size()));
  std::vector<double> difference(a.size());
  PairedComparison c;
  for (std::size_t i = 0; i < a.size(); ++i) {
    difference[i] = lower_is_better ? b[i] - a[i] : a[i] - b[i];
    if (difference[i] > 0) ++c.holds;
  }
  c.n = int(a.size());
  c.difference = summarize_sample(difference, confidence);
  if (c.n >= 2 && c.difference.ci_low > 0)
    c.verdict = "holds";
  else if (c.n >= 2 && c.difference.ci_high < 0)
    c.verdict = "reversed";
  return c;
}

}  // namespace panoscan::eval
