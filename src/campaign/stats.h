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

struct SignedRank {
  double w_plus = 0;  ///< the sum of the ranks of the positive differences (ties: mean ranks)
  long n = 0;         ///< the nonzero differences ranked
  double p = 1;       ///< two-sided
};
/// The Wilcoxon signed-rank test of paired differences (zeros dropped; Wilcoxon 1945): the exact
/// distribution of W+ for up to 50 pairs (ranks doubled to integers, so tied ranks count too),
/// else the normal approximation with the tie correction.
SignedRank wilcoxonSignedRank(const std::vector<double>& differences);

/// The smallest ratio a paired comparison of `n` log ratios (the same trials timed on both sides)
/// with this standard deviation detects at this two-sided alpha with power 0.8 (the normal
/// approximation; the signed-rank test's efficiency against it, 3/pi ~ 0.955, ignored).
double minimumDetectablePairedRatio(long n, double log_ratio_sd, double alpha = 0.05);

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
