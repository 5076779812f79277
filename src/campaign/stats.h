// Small statistics for campaign summaries.
#pragma once
#include <utility>
#include <vector>

namespace mm {

/// Wilson score interval for k successes in n trials at 95% (z = 1.96). Wilson 1927.
std::pair<double, double> wilson95(long k, long n);

struct Moments {
  long n = 0;
  double mean = 0, std = 0, min = 0, max = 0;
};
/// Mean, population standard deviation, min and max (zeros when empty).
Moments moments(const std::vector<double>& v);

/// McNemar's exact test of paired successes (two-sided): `b` pairs went success -> failure, `c`
/// failure -> success; under no change each such discordant pair goes either way with 1/2.
/// McNemar 1947; the exact form is the binomial test on b of b + c.
double mcnemarExactP(long b, long c);

struct MannWhitney {
  double u = 0;  ///< U of the first sample (pairs where it is larger, ties 1/2)
  double z = 0;  ///< normal approximation, tie-corrected, continuity-corrected
  double p = 1;  ///< two-sided
};
/// The Mann–Whitney U test of two independent samples (Mann & Whitney 1947), normal approximation
/// with the tie correction; meant for samples of 8 or more each.
MannWhitney mannWhitneyU(const std::vector<double>& x, const std::vector<double>& y);

/// The smallest ratio of medians a two-sample comparison of log timings with these sizes and this
/// spread (standard deviation of the logs) detects at this two-sided alpha with power 0.8 (the
/// normal approximation; Mann–Whitney's efficiency against it is 3/pi ~ 0.955, ignored).
double minimumDetectableRatio(long n1, long n2, double log_sd, double alpha = 0.05);

/// Running moments in constant memory whose result does not depend on the order of the values
/// (a campaign's trials arrive in any order from its workers, its shards in any order at a merge):
/// values are summed as exact integers of 1e-9 (their squares of 1e-18), so the sums are exact and
/// associative; the mean and deviation agree with moments() to ~1e-9 of a unit. The sum of squares
/// holds 1e7 values of magnitude up to ~1e5 (it overflows past ~1.7e38 / 1e18); non-finite values
/// are skipped.
class ExactMoments {
 public:
  void add(double x);
  Moments get() const;

 private:
  long n_ = 0;
  __extension__ typedef __int128 Int128;
  Int128 sum_ = 0, sum_sq_ = 0;
  double min_ = 0, max_ = 0;
};

}  // namespace mm
